#include "server/broker.h"

#include <spdlog/spdlog.h>

#include <thread>
#include <zmq.hpp>

#include "common/util/mutex.h"
#include "common/util/thread_annotations.h"
#include "server/zap_handler.h"

namespace sceneloc {
namespace {

constexpr char kControlEndpoint[] = "inproc://sceneloc-broker-control";

class ZmqBroker final : public Broker {
 public:
  explicit ZmqBroker(const BrokerOptions& options)
      : options_(options),
        frontend_(context_, zmq::socket_type::router),
        backend_(context_, zmq::socket_type::dealer),
        control_(context_, zmq::socket_type::pair),
        stop_(context_, zmq::socket_type::pair) {}

  ~ZmqBroker() override { Stop(); }

  Status Bind() EXCLUDES(stop_mutex_) {
    // Nothing else runs yet; the lock is for the analysis (stop_ and thread_ are Stop()'s).
    MutexLock lock(&stop_mutex_);
    if (options_.auth.enabled) {
      // Bound before the frontend, so that no client is ever admitted unchecked.
      auto zap = ZapHandler::Start(context_, options_.auth);
      if (!zap.ok()) return zap.status();
      zap_ = std::move(zap).value();
    }
    std::string where;
    try {
      where = options_.frontend;
      if (zap_ != nullptr) zap_->Secure(&frontend_);
      frontend_.set(zmq::sockopt::maxmsgsize, options_.max_message_bytes);
      frontend_.set(zmq::sockopt::linger, 0);
      frontend_.bind(options_.frontend);
      where = options_.backend;
      backend_.set(zmq::sockopt::linger, 0);
      backend_.bind(options_.backend);
      where = kControlEndpoint;
      control_.bind(kControlEndpoint);
      stop_.connect(kControlEndpoint);
    } catch (const zmq::error_t& e) {
      return IoError("cannot bind '" + where + "': " + e.what());
    }
    frontend_endpoint_ = frontend_.get(zmq::sockopt::last_endpoint);
    backend_endpoint_ = backend_.get(zmq::sockopt::last_endpoint);
    // The sockets move to the proxy's thread here; thread creation orders the accesses.
    thread_ = std::thread([this] { Forward(); });
    return Status::Ok();
  }

  std::string frontend() const override { return frontend_endpoint_; }
  std::string backend() const override { return backend_endpoint_; }

  Status ReloadClients() override {
    if (zap_ == nullptr) return FailedPrecondition("the broker runs without auth");
    return zap_->ReloadClients();
  }

  void Stop() override EXCLUDES(stop_mutex_) {
    MutexLock lock(&stop_mutex_);
    if (!thread_.joinable()) return;
    try {
      stop_.send(zmq::str_buffer("TERMINATE"), zmq::send_flags::none);
    } catch (const zmq::error_t& e) {
      spdlog::error("broker: cannot stop the proxy: {}", e.what());
    }
    thread_.join();
    if (zap_ != nullptr) {
      spdlog::info("broker: {} connection(s) admitted, {} refused", zap_->admitted(),
                   zap_->refused());
    }
  }

 private:
  void Forward() {
    try {
      zmq::proxy_steerable(frontend_, backend_, zmq::socket_ref(), control_);
    } catch (const zmq::error_t& e) {
      // ETERM only when the context ends under it; anything else is worth a line.
      if (e.num() != ETERM) spdlog::error("broker: the proxy stopped: {}", e.what());
    }
    frontend_.close();
    backend_.close();
    control_.close();
  }

  const BrokerOptions options_;
  zmq::context_t context_;
  // Set by Bind() (with auth) before the proxy starts; its own thread answers ZAP requests.
  std::unique_ptr<ZapHandler> zap_;
  // Owned by the proxy's thread once it runs.
  zmq::socket_t frontend_;
  zmq::socket_t backend_;
  zmq::socket_t control_;
  // Constant after Bind().
  std::string frontend_endpoint_;
  std::string backend_endpoint_;

  Mutex stop_mutex_;
  // Guarded by stop_mutex_.
  zmq::socket_t stop_ GUARDED_BY(stop_mutex_);  // Stop()'s end of the control pair
  std::thread thread_ GUARDED_BY(stop_mutex_);  // the proxy's thread
};

}  // namespace

Status BrokerOptions::Validate() const {
  if (frontend.empty()) return InvalidArgument("broker frontend endpoint must be set");
  if (backend.empty()) return InvalidArgument("broker backend endpoint must be set");
  // The same endpoint twice could never bind (tcp://host:* asks for two ports: fine).
  if (frontend == backend && frontend.find(":*") == std::string::npos) {
    return InvalidArgument("broker frontend and backend must differ (both '" + frontend + "')");
  }
  if (max_message_bytes < 1024) return InvalidArgument("max_message_bytes must be >= 1024");
  return auth.Validate();
}

StatusOr<std::unique_ptr<Broker>> Broker::Start(const BrokerOptions& options) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  auto broker = std::make_unique<ZmqBroker>(options);
  SCENELOC_RETURN_IF_ERROR(broker->Bind());
  return std::unique_ptr<Broker>(std::move(broker));
}

}  // namespace sceneloc
