#include "tests/server/server_call_support.h"

#include <chrono>
#include <iterator>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <zmq_addon.hpp>

#include "proto/wire.h"

namespace sceneloc::test {

void SendFrames(zmq::socket_t* socket, const std::vector<std::string>& frames) {
  for (size_t i = 0; i < frames.size(); ++i) {
    socket->send(zmq::buffer(frames[i]),
                 i + 1 < frames.size() ? zmq::send_flags::sndmore : zmq::send_flags::none);
  }
}

std::vector<std::string> ReceiveFrames(zmq::socket_t* socket) {
  zmq::pollitem_t item{socket->handle(), 0, ZMQ_POLLIN, 0};
  if (zmq::poll(&item, 1, std::chrono::seconds(20)) == 0) {
    ADD_FAILURE() << "no reply";
    return {};
  }
  std::vector<zmq::message_t> parts;
  (void)zmq::recv_multipart(*socket, std::back_inserter(parts));
  std::vector<std::string> frames;
  for (const zmq::message_t& part : parts) frames.push_back(part.to_string());
  return frames;
}

v1::Reply ParseReply(const std::vector<std::string>& frames) {
  v1::Reply reply;
  EXPECT_TRUE(!frames.empty() && reply.ParseFromString(frames.back()));
  return reply;
}

std::vector<std::string> RawExchange(const std::string& endpoint,
                                     const std::vector<std::string>& frames) {
  zmq::context_t context;
  zmq::socket_t socket(context, zmq::socket_type::dealer);
  socket.set(zmq::sockopt::linger, 0);
  socket.connect(endpoint);
  SendFrames(&socket, frames);
  return ReceiveFrames(&socket);
}

v1::Reply RawCall(const std::string& endpoint, const std::vector<std::string>& frames) {
  return ParseReply(RawExchange(endpoint, frames));
}

std::unique_ptr<Client> MustConnect(const std::string& endpoint, int timeout_ms) {
  ClientOptions options;
  options.timeout_ms = timeout_ms;
  options.retries = 0;
  auto client = Client::Connect(endpoint, options);
  EXPECT_TRUE(client.ok()) << client.status().ToString();
  return client.ok() ? std::move(client).value() : nullptr;
}

ServerOptions OneWorkerOptions() {
  ServerOptions options = TestServerOptions();
  options.threads = 1;
  return options;
}

v1::Request LocaliseFeatures(const FeatureSet& features) {
  v1::Request request;
  request.mutable_localise()->set_map(kTestMapName);
  EncodeFeatureSet(features, DescriptorEncoding::kFloat32,
                   request.mutable_localise()->mutable_features());
  return request;
}

v1::Request LocaliseJpeg(const std::string& jpeg) {
  v1::Request request;
  request.mutable_localise()->set_map(kTestMapName);
  request.mutable_localise()->set_jpeg(jpeg);
  return request;
}

std::string LargeJpeg(int i) {
  cv::Mat image =
      cv::imdecode(cv::Mat(1, static_cast<int>(TourJpegs()[static_cast<size_t>(i)].size()), CV_8U,
                           const_cast<char*>(TourJpegs()[static_cast<size_t>(i)].data())),
                   cv::IMREAD_COLOR);
  cv::Mat large;
  cv::resize(image, large, cv::Size(2400, 1350), 0, 0, cv::INTER_CUBIC);
  std::vector<uint8_t> bytes;
  cv::imencode(".jpg", large, bytes, {cv::IMWRITE_JPEG_QUALITY, 95});
  return std::string(bytes.begin(), bytes.end());
}

zmq::socket_t SendBurst(zmq::context_t* context, const std::string& endpoint, v1::Request request,
                        int count) {
  zmq::socket_t socket(*context, zmq::socket_type::dealer);
  socket.set(zmq::sockopt::linger, 0);
  socket.connect(endpoint);
  for (int i = 1; i <= count; ++i) {
    request.set_request_id(static_cast<uint64_t>(i));
    socket.send(zmq::message_t(), zmq::send_flags::sndmore);
    socket.send(zmq::buffer(request.SerializeAsString()), zmq::send_flags::none);
  }
  return socket;
}

std::set<uint64_t> CollectReplies(zmq::socket_t* socket, int count,
                                  const std::function<void(const v1::Reply&)>& check) {
  std::set<uint64_t> ids;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (static_cast<int>(ids.size()) < count && std::chrono::steady_clock::now() < deadline) {
    zmq::pollitem_t item{socket->handle(), 0, ZMQ_POLLIN, 0};
    if (zmq::poll(&item, 1, std::chrono::seconds(1)) == 0) continue;
    std::vector<zmq::message_t> parts;
    if (!zmq::recv_multipart(*socket, std::back_inserter(parts))) {
      ADD_FAILURE() << "receive failed";
      break;
    }
    v1::Reply reply;
    if (!reply.ParseFromArray(parts.back().data(), static_cast<int>(parts.back().size()))) {
      ADD_FAILURE() << "a reply that is not a sceneloc.v1.Reply";
      continue;
    }
    EXPECT_TRUE(ids.insert(reply.request_id()).second) << "two replies to " << reply.request_id();
    check(reply);
  }
  return ids;
}

Burst::Burst(const std::string& endpoint, const v1::Request& request, int count)
    : count_(count), socket_(SendBurst(&context_, endpoint, request, count)) {}

Burst::Counts Burst::CountOkOr(v1::StatusCode refusal, const std::string& why) {
  Counts counts;
  counts.ids = CollectReplies(&socket_, count_, [&](const v1::Reply& reply) {
    if (reply.status() == v1::OK) {
      ++counts.ok;
      return;
    }
    ++counts.refused;
    EXPECT_EQ(reply.status(), refusal) << reply.error();
    EXPECT_NE(reply.error().find(why), std::string::npos) << reply.error();
  });
  return counts;
}

std::optional<v1::StatsReply> AwaitRequests(Client* client, uint64_t count) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  for (uint64_t calls = 1;; ++calls) {
    auto stats = client->Stats();
    if (!stats.ok()) {
      ADD_FAILURE() << stats.status().ToString();
      return std::nullopt;
    }
    if (stats->requests() >= count + calls) return *std::move(stats);
    if (std::chrono::steady_clock::now() >= deadline) {
      ADD_FAILURE() << "the server read " << stats->requests() - calls << " of " << count
                    << " requests in 20 s";
      return std::nullopt;
    }
  }
}

}  // namespace sceneloc::test
