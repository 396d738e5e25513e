// The tools of hostile_server (bench/hostile_server.cc): sceneloc-server as a child
// process, the well-behaved client that localises throughout the attacks, and the ways of
// sending raw requests at a server.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <thread>
#include <vector>
#include <zmq.hpp>

#include "client/client.h"
#include "common/util/mutex.h"
#include "common/util/thread_annotations.h"

namespace sceneloc::hostile {

using Clock = std::chrono::steady_clock;

inline double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

// The whole file at `path` (empty when it cannot be read).
std::string ReadAll(const std::string& path);

// sceneloc-server as a child process, its output in a log file.
class ServerChild {
 public:
  ServerChild(const std::string& bin, const std::string& maps, int threads, const std::string& log)
      : log_(log) {
    pid_ = fork();
    if (pid_ == 0) {
      FILE* f = std::freopen(log.c_str(), "w", stdout);
      if (f == nullptr || dup2(STDOUT_FILENO, STDERR_FILENO) < 0) _exit(127);
      execl(bin.c_str(), bin.c_str(), "--maps", maps.c_str(), "--endpoint", "tcp://127.0.0.1:*",
            "--threads", std::to_string(threads).c_str(), "--log-level", "info",
            "--summary-interval", "0", static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  ~ServerChild() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
    }
  }
  // The endpoint from the "serving ... on tcp://..." log line; empty after 60 s.
  std::string WaitForEndpoint() const {
    for (int i = 0; i < 600; ++i) {
      const std::string log = ReadAll(log_);
      const size_t at = log.find(" on tcp://");
      if (at != std::string::npos) return log.substr(at + 4, log.find(' ', at + 4) - at - 4);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return {};
  }
  bool alive() const {
    return pid_ > 0 && kill(pid_, 0) == 0 && waitpid(pid_, nullptr, WNOHANG) == 0;
  }
  double RssMb() const {
    std::ifstream in("/proc/" + std::to_string(pid_) + "/status");
    std::string line;
    while (std::getline(in, line)) {
      if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
    }
    return 0;
  }
  void Signal(int signal) const { kill(pid_, signal); }

 private:
  std::string log_;
  pid_t pid_ = -1;
};

// The well-behaved client: one JPEG every 500 ms, each call's start and latency recorded.
// It is sceneloc::Client with its defaults but for timeouts: no retry after a timeout (a
// stalled server shows), and OVERLOADED waited out as a robot's client does (the time
// spent waiting counts in the call's latency; the retries are counted).
class GoodClient {
 public:
  GoodClient(const std::string& endpoint, std::string jpeg) : jpeg_(std::move(jpeg)) {
    ClientOptions options;
    options.timeout_ms = 30000;
    options.retries = 0;
    client_ = std::move(Client::Connect(endpoint, options)).value();
    thread_ = std::thread([this] { Run(); });
  }
  ~GoodClient() {
    stop_ = true;
    thread_.join();
  }
  // Latencies (ms) of calls started in [from, to], the failures among them and the first
  // failure's message.
  std::vector<double> Latencies(Clock::time_point from, Clock::time_point to, int* failures,
                                std::string* first_error = nullptr,
                                int* overload_retries = nullptr) const EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    std::vector<double> out;
    *failures = 0;
    if (overload_retries != nullptr) *overload_retries = 0;
    for (const Call& c : calls_) {
      if (c.start < from || c.start > to) continue;
      if (overload_retries != nullptr) *overload_retries += c.overload_retries;
      out.push_back(c.ms);
      if (!c.ok && *failures == 0 && first_error != nullptr) *first_error = c.error;
      *failures += !c.ok;
    }
    return out;
  }

 private:
  struct Call {
    Clock::time_point start;
    double ms;
    bool ok;
    std::string error;  // why it failed
    int64_t overload_retries;
  };
  void Run() EXCLUDES(mutex_) {
    while (!stop_) {
      const Clock::time_point start = Clock::now();
      const int64_t retries_before = client_->overload_retries();
      const auto reply = client_->Localise("gp", jpeg_);
      {
        MutexLock lock(&mutex_);
        calls_.push_back({start, Ms(Clock::now() - start), reply.ok(),
                          reply.ok() ? std::string() : reply.status().message(),
                          client_->overload_retries() - retries_before});
      }
      std::this_thread::sleep_until(start + std::chrono::milliseconds(500));
    }
  }
  // Constant after construction.
  const std::string jpeg_;
  // Run()'s thread only, once it runs.
  std::unique_ptr<Client> client_;

  mutable Mutex mutex_;
  // Guarded by mutex_.
  std::vector<Call> calls_ GUARDED_BY(mutex_);

  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// Sends `requests` on one DEALER each (or all on one when `one_socket`) and, unless
// `read` is false, collects the replies' statuses for up to `wait` (NO_REPLY for the rest).
// The sockets go to `keep` when given (connections held open).
std::map<std::string, int> Fire(zmq::context_t& ctx, const std::string& endpoint,
                                const std::vector<std::string>& requests, bool one_socket,
                                bool read, std::chrono::seconds wait,
                                std::vector<zmq::socket_t>* keep = nullptr);

// `connections` threads, each with its own context and one connection, each sending all of
// `batch` at once and reading the replies for up to `wait`: the statuses, summed.
std::map<std::string, int> FireFromThreads(const std::string& endpoint,
                                           const std::vector<std::string>& batch, int connections,
                                           std::chrono::seconds wait);

// A serialised localise request of `jpeg` against the map "gp".
std::string Localise(const std::string& jpeg);

// A serialised localise request of a feature set holding `keypoints` empty keypoints (two
// bytes each on the wire, a message each once parsed) and nothing else, against "gp".
std::string EmptyKeypoints(int keypoints, int width, int height);

// `image` as a JPEG of quality 80, baseline or progressive.
std::string Encode(const cv::Mat& image, bool progressive);

// The JPEG with its last scan repeated `extra` times before the end-of-image marker.
std::string WithExtraScans(const std::string& jpeg, int extra);

// "OK=3 OVERLOADED=2", or "(not read)" when empty.
std::string Statuses(const std::map<std::string, int>& s);

}  // namespace sceneloc::hostile
