// sceneloc-server as a user runs it: a child process, its log, signals and exit status.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <zmq.hpp>
#include <zmq_addon.hpp>

#include "client/client.h"
#include "proto/wire.h"
#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

using Clock = std::chrono::steady_clock;

// A sceneloc-server child with its stdout and stderr on a pipe.
class ServerProcess {
 public:
  explicit ServerProcess(std::vector<std::string> args) {
    int fds[2];
    if (pipe(fds) != 0) std::abort();
    pid_ = fork();
    if (pid_ == 0) {
      dup2(fds[1], STDOUT_FILENO);
      dup2(fds[1], STDERR_FILENO);
      close(fds[0]);
      close(fds[1]);
      args.insert(args.begin(), SCENELOC_SERVER_BIN);
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(argv[0], argv.data());
      _exit(127);
    }
    close(fds[1]);
    fd_ = fds[0];
  }
  ~ServerProcess() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    close(fd_);
  }

  // Reads output until it contains `text` or the child closes it / the deadline passes.
  bool WaitForOutput(const std::string& text, std::chrono::seconds timeout) {
    const auto deadline = Clock::now() + timeout;
    while (output_.find(text) == std::string::npos) {
      if (!ReadSome(deadline)) return false;
    }
    return true;
  }

  // Reads to end of output, then reaps the child; its exit status, or -1.
  int Wait(std::chrono::seconds timeout) {
    const auto deadline = Clock::now() + timeout;
    while (ReadSome(deadline)) {
    }
    int status = 0;
    if (waitpid(pid_, &status, Clock::now() < deadline ? 0 : WNOHANG) != pid_) return -1;
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  void Signal(int signal) { kill(pid_, signal); }
  const std::string& output() const { return output_; }

 private:
  bool ReadSome(Clock::time_point deadline) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    if (left.count() <= 0) return false;
    pollfd p{fd_, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left.count())) <= 0) return false;
    char buffer[4096];
    const ssize_t n = read(fd_, buffer, sizeof(buffer));
    if (n <= 0) return false;
    output_.append(buffer, static_cast<size_t>(n));
    return true;
  }

  pid_t pid_ = -1;
  int fd_ = -1;
  std::string output_;
};

// The endpoint the server logged ("serving N map(s) on tcp://127.0.0.1:PORT with ...").
std::string LoggedEndpoint(const std::string& output) {
  const size_t on = output.find(" on tcp://");
  if (on == std::string::npos) return "";
  const size_t end = output.find(' ', on + 4);
  return output.substr(on + 4, end - on - 4);
}

// SIGTERM with requests in flight: every request is answered, the server exits 0.
TEST(ServerProcessTest, SigtermDrainsInFlightRequestsAndExitsZero) {
  ServerProcess server({"--maps", test::TestMapsDir(), "--endpoint", "tcp://127.0.0.1:*",
                        "--threads", "1", "--summary-interval", "0", "--log-level", "info"});
  ASSERT_TRUE(server.WaitForOutput("serving", std::chrono::seconds(30))) << server.output();
  const std::string endpoint = LoggedEndpoint(server.output());
  ASSERT_FALSE(endpoint.empty()) << server.output();
  // The log says which build is serving, as --version prints it.
  ServerProcess version({"--version"});
  EXPECT_EQ(version.Wait(std::chrono::seconds(20)), 0);
  ASSERT_EQ(version.output().rfind("0.", 0), 0u) << version.output();
  EXPECT_NE(server.output().find("sceneloc-server " + version.output()), std::string::npos)
      << server.output();

  zmq::context_t context;
  zmq::socket_t socket(context, zmq::socket_type::dealer);
  socket.set(zmq::sockopt::linger, 0);
  socket.connect(endpoint);
  constexpr int kRequests = 5;
  v1::Request request;
  request.mutable_localise()->set_map(test::kTestMapName);
  EncodeFeatureSet(test::TourFeatures(2), DescriptorEncoding::kFloat32,
                   request.mutable_localise()->mutable_features());
  for (int i = 1; i <= kRequests; ++i) {
    request.set_request_id(static_cast<uint64_t>(i));
    socket.send(zmq::message_t(), zmq::send_flags::sndmore);
    socket.send(zmq::buffer(request.SerializeAsString()), zmq::send_flags::none);
  }
  // Signal once the server holds them all (its Stats counts them, and every Stats call
  // so far, this one included).
  ClientOptions options;
  options.timeout_ms = 20000;
  auto client = Client::Connect(endpoint, options);
  ASSERT_TRUE(client.ok());
  const auto deadline = Clock::now() + std::chrono::seconds(20);
  for (uint64_t calls = 1;; ++calls) {
    auto stats = (*client)->Stats();
    ASSERT_TRUE(stats.ok()) << stats.status().ToString();
    if (stats->requests() >= kRequests + calls) break;
    ASSERT_LT(Clock::now(), deadline);
  }
  server.Signal(SIGTERM);

  int ok = 0;
  for (int n = 0; n < kRequests; ++n) {
    zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
    if (zmq::poll(&item, 1, std::chrono::seconds(20)) == 0) break;
    std::vector<zmq::message_t> parts;
    ASSERT_TRUE(zmq::recv_multipart(socket, std::back_inserter(parts)));
    v1::Reply reply;
    ASSERT_TRUE(reply.ParseFromArray(parts.back().data(), static_cast<int>(parts.back().size())));
    EXPECT_EQ(reply.status(), v1::OK) << reply.error();
    ok += reply.status() == v1::OK;
  }
  EXPECT_EQ(ok, kRequests);
  EXPECT_EQ(server.Wait(std::chrono::seconds(30)), 0) << server.output();
  EXPECT_NE(server.output().find("SIGTERM"), std::string::npos);
}

// SIGHUP reloads every map file in the folder (with the watch off, so only the signal can
// have done it): the served map's generation goes up, and a new file becomes a map.
TEST(ServerProcessTest, SighupReloadsTheMaps) {
  test::TempMapsDir dir("sighup");
  ServerProcess server({"--maps", dir.path(), "--endpoint", "tcp://127.0.0.1:*", "--watch-maps",
                        "false", "--summary-interval", "0", "--log-level", "info"});
  ASSERT_TRUE(server.WaitForOutput("serving", std::chrono::seconds(30))) << server.output();
  ClientOptions options;
  options.timeout_ms = 20000;
  auto client = Client::Connect(LoggedEndpoint(server.output()), options);
  ASSERT_TRUE(client.ok());
  auto before = (*client)->ListMaps();
  ASSERT_TRUE(before.ok()) << before.status().ToString();
  ASSERT_EQ(before->maps_size(), 1);
  EXPECT_EQ(before->maps(0).version().generation(), 1u);

  std::filesystem::copy_file(dir.MapPath(), dir.MapPath("annex"));
  server.Signal(SIGHUP);
  ASSERT_TRUE(server.WaitForOutput("map synthetic generation 2", std::chrono::seconds(20)))
      << server.output();
  ASSERT_TRUE(server.WaitForOutput("map annex generation 1", std::chrono::seconds(20)))
      << server.output();
  auto after = (*client)->ListMaps();
  ASSERT_TRUE(after.ok());
  ASSERT_EQ(after->maps_size(), 2);
  EXPECT_EQ(after->maps(0).version().name(), "annex");
  EXPECT_EQ(after->maps(1).version().generation(), 2u);
  auto reply = (*client)->Localise(test::kTestMapName, test::TourFeatures(3));
  ASSERT_TRUE(reply.ok()) << reply.status().ToString();
  EXPECT_EQ(reply->map().generation(), 2u);
  EXPECT_NE(server.output().find("SIGHUP"), std::string::npos);

  server.Signal(SIGTERM);
  EXPECT_EQ(server.Wait(std::chrono::seconds(30)), 0) << server.output();
}

// A 100 GB sparse map file in the maps folder neither stops the server nor keeps it from
// starting, at start or on SIGHUP: it is logged and skipped, the good map serves, and a
// file that is not a map by its name is named.
TEST(ServerProcessTest, HugeMapFileIsSkippedAtStartAndOnSighup) {
  test::TempMapsDir dir("hostile");
  const std::string huge = dir.MapPath("huge");
  std::ofstream(huge) << std::string(64, '\0');
  ASSERT_EQ(::truncate(huge.c_str(), off_t{100} << 30), 0);
  std::ofstream(std::filesystem::path(dir.path()) / "lab.map") << "a map by another name";
  ServerProcess server({"--maps", dir.path(), "--endpoint", "tcp://127.0.0.1:*", "--watch-maps",
                        "false", "--summary-interval", "0", "--log-level", "info"});
  ASSERT_TRUE(server.WaitForOutput("serving 1 map", std::chrono::seconds(30))) << server.output();
  EXPECT_NE(server.output().find("huge.scnl"), std::string::npos) << server.output();
  EXPECT_NE(server.output().find("lab.map"), std::string::npos) << server.output();
  server.Signal(SIGHUP);
  ASSERT_TRUE(server.WaitForOutput("map synthetic generation 2", std::chrono::seconds(20)))
      << server.output();
  ClientOptions options;
  options.timeout_ms = 20000;
  auto client = Client::Connect(LoggedEndpoint(server.output()), options);
  ASSERT_TRUE(client.ok());
  auto reply = (*client)->Localise(test::kTestMapName, test::TourFeatures(3));
  ASSERT_TRUE(reply.ok()) << reply.status().ToString();
  server.Signal(SIGTERM);
  EXPECT_EQ(server.Wait(std::chrono::seconds(30)), 0) << server.output();
}

// A settings error stops the server at start with status 2 and a message naming it.
TEST(ServerProcessTest, BadSettingsExitTwo) {
  ServerProcess bad_flag({"--threads", "0"});
  EXPECT_EQ(bad_flag.Wait(std::chrono::seconds(20)), 2);
  EXPECT_NE(bad_flag.output().find("--threads"), std::string::npos) << bad_flag.output();
  ServerProcess missing_dir({"--maps", "/nonexistent/maps", "--endpoint", "tcp://127.0.0.1:*"});
  EXPECT_EQ(missing_dir.Wait(std::chrono::seconds(20)), 2);
  EXPECT_NE(missing_dir.output().find("/nonexistent/maps"), std::string::npos)
      << missing_dir.output();
}

}  // namespace
}  // namespace sceneloc
