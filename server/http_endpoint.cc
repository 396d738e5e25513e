#include "server/http_endpoint.h"

#include <arpa/inet.h>
#include <civetweb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <charconv>
#include <chrono>
#include <exception>
#include <mutex>
#include <thread>
#include <utility>

#include "common/util/mutex.h"
#include "common/util/thread_annotations.h"

namespace sceneloc {
namespace {

const char* Reason(int status) {
  switch (status) {
    case 200:
      return "OK";
    case 404:
      return "Not Found";
    case 405:
      return "Method Not Allowed";
    case 500:
      return "Internal Server Error";
    case 503:
      return "Service Unavailable";
    default:
      return "";
  }
}

int Send(mg_connection* conn, const HttpResponse& response) {
  mg_printf(conn,
            "HTTP/1.1 %d %s\r\nContent-Type: %s\r\nContent-Length: %zu\r\n"
            "Cache-Control: no-store\r\nConnection: close\r\n\r\n",
            response.status, Reason(response.status), response.content_type.c_str(),
            response.body.size());
  mg_write(conn, response.body.data(), response.body.size());
  return response.status;
}

class CivetEndpoint final : public HttpEndpoint {
 public:
  explicit CivetEndpoint(std::map<std::string, Handler> handlers)
      : handlers_(std::move(handlers)) {}
  ~CivetEndpoint() override { Stop(); }

  Status Listen(const std::string& address) EXCLUDES(stop_mutex_) {
    // Nothing else runs yet; the lock is for the analysis (context_ is Stop()'s).
    MutexLock lock(&stop_mutex_);
    static std::once_flag library;
    std::call_once(library, [] { mg_init_library(0); });
    // Two threads: scrapes and probes are rare; a third caller waits its turn (civetweb
    // queues accepted connections). No document_root: nothing is served from disk.
    const char* options[] = {
        "listening_ports", address.c_str(),     "num_threads", "2",    "request_timeout_ms",
        "10000",           "enable_keep_alive", "no",          nullptr};
    mg_callbacks callbacks{};
    callbacks.log_message = [](const mg_connection*, const char*) { return 1; };  // quiet
    mg_init_data init{&callbacks, this, options};
    std::array<char, 256> text{};
    unsigned code = 0;
    mg_error_data error{&code, text.data(), text.size()};
    context_ = mg_start2(&init, &error);
    if (context_ == nullptr) {
      return IoError("cannot listen for HTTP on '" + address + "': " +
                     (text[0] != '\0' ? std::string(text.data()) : "civetweb failed to start") +
                     " (is the port taken?)");
    }
    mg_set_request_handler(context_, "/", &CivetEndpoint::Dispatch, this);
    std::array<mg_server_port, 4> ports{};
    const int n = mg_get_server_ports(context_, static_cast<int>(ports.size()), ports.data());
    const std::string host = address.substr(0, address.rfind(':'));
    port_ = static_cast<uint16_t>(n > 0 ? ports[0].port : 0);
    address_ = host + ":" + std::to_string(port_);
    return Status::Ok();
  }

  std::string address() const override { return address_; }

  void Stop() override EXCLUDES(stop_mutex_) {
    MutexLock lock(&stop_mutex_);
    if (context_ == nullptr) return;
    // mg_stop() raises civetweb's stop flag and joins its threads; its listener notices
    // the flag only when its poll() returns, which without a connection takes up to 2 s
    // (SOCKET_TIMEOUT_QUANTUM). Connecting to it wakes it at once.
    std::atomic<bool> stopped{false};
    std::thread stopper([context = context_, &stopped] {
      mg_stop(context);
      stopped = true;
    });
    while (!stopped) {
      PokeListener();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    stopper.join();
    context_ = nullptr;
  }

 private:
  static int Dispatch(mg_connection* conn, void* self) {
    return static_cast<CivetEndpoint*>(self)->Handle(conn);
  }

  int Handle(mg_connection* conn) const {
    const mg_request_info* info = mg_get_request_info(conn);
    if (std::string(info->request_method) != "GET") {
      return Send(conn, {405, "text/plain; charset=utf-8", "only GET is served\n"});
    }
    const auto it = handlers_.find(info->local_uri != nullptr ? info->local_uri : "");
    if (it == handlers_.end()) {
      std::string paths;
      for (const auto& [path, handler] : handlers_) paths += " " + path;
      return Send(conn, {404, "text/plain; charset=utf-8", "no such path; served:" + paths + "\n"});
    }
    try {
      return Send(conn, it->second());
    } catch (const std::exception& e) {
      return Send(conn, {500, "text/plain; charset=utf-8", std::string(e.what()) + "\n"});
    }
  }

  // Opens and closes one TCP connection to the listening port (IPv4 hosts; others wait
  // for civetweb's own poll timeout).
  void PokeListener() const {
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(port_);
    const std::string host = address_.substr(0, address_.rfind(':'));
    if (inet_pton(AF_INET, host == "0.0.0.0" ? "127.0.0.1" : host.c_str(), &addr.sin_addr) != 1) {
      return;
    }
    const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return;
    (void)connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));
    close(fd);
  }

  // Constant after construction.
  const std::map<std::string, Handler> handlers_;
  // Constant after Listen().
  std::string address_;
  uint16_t port_ = 0;

  Mutex stop_mutex_;
  // Guarded by stop_mutex_.
  mg_context* context_ GUARDED_BY(stop_mutex_) = nullptr;  // null before Listen(), after Stop()
};

}  // namespace

Status ValidateHttpAddress(const std::string& address) {
  const size_t colon = address.rfind(':');
  int port = -1;
  if (colon != std::string::npos && colon > 0) {
    const char* begin = address.data() + colon + 1;
    const char* end = address.data() + address.size();
    const auto [ptr, ec] = std::from_chars(begin, end, port);
    if (ec != std::errc() || ptr != end || begin == end) port = -1;
  }
  if (port < 0 || port > 65535) {
    return InvalidArgument("HTTP address '" + address +
                           "' is not HOST:PORT (e.g. 127.0.0.1:9464, 0.0.0.0:9464)");
  }
  return Status::Ok();
}

StatusOr<std::unique_ptr<HttpEndpoint>> HttpEndpoint::Start(
    const std::string& address, std::map<std::string, Handler> handlers) {
  const Status valid = ValidateHttpAddress(address);
  if (!valid.ok()) return valid;
  auto endpoint = std::make_unique<CivetEndpoint>(std::move(handlers));
  const Status listening = endpoint->Listen(address);
  if (!listening.ok()) return listening;
  return std::unique_ptr<HttpEndpoint>(std::move(endpoint));
}

}  // namespace sceneloc
