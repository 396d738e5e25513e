#include "bench/hostile_tools.h"

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "proto/wire.h"

namespace sceneloc::hostile {

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Sends `requests` on one DEALER each (or all on one when `one_socket`) and, unless
// `read` is false, collects the replies' statuses for up to `wait`.
std::map<std::string, int> Fire(zmq::context_t& ctx, const std::string& endpoint,
                                const std::vector<std::string>& requests, bool one_socket,
                                bool read, std::chrono::seconds wait,
                                std::vector<zmq::socket_t>* keep) {
  std::vector<zmq::socket_t> sockets;
  for (size_t i = 0; i < requests.size(); ++i) {
    if (!one_socket || sockets.empty()) {
      sockets.emplace_back(ctx, zmq::socket_type::dealer);
      sockets.back().set(zmq::sockopt::linger, 0);
      sockets.back().set(zmq::sockopt::sndhwm, 0);
      sockets.back().connect(endpoint);
    }
    sockets.back().send(zmq::message_t(), zmq::send_flags::sndmore);
    sockets.back().send(zmq::buffer(requests[i]), zmq::send_flags::none);
  }
  std::map<std::string, int> statuses;
  if (read) {
    size_t got = 0;
    const Clock::time_point deadline = Clock::now() + wait;
    while (got < requests.size() && Clock::now() < deadline) {
      std::vector<zmq::pollitem_t> items;
      for (auto& s : sockets) items.push_back({s.handle(), 0, ZMQ_POLLIN, 0});
      if (zmq::poll(items, std::chrono::milliseconds(200)) == 0) continue;
      for (size_t i = 0; i < items.size(); ++i) {
        if (!(items[i].revents & ZMQ_POLLIN)) continue;
        zmq::message_t frame;
        bool more = true;
        v1::Reply reply;
        while (more && sockets[i].recv(frame, zmq::recv_flags::dontwait)) {
          more = frame.more();
          if (!more && reply.ParseFromArray(frame.data(), static_cast<int>(frame.size()))) {
            ++statuses[v1::StatusCode_Name(reply.status())];
            ++got;
          }
        }
      }
    }
    if (got < requests.size()) statuses["NO_REPLY"] += static_cast<int>(requests.size() - got);
  }
  if (keep != nullptr) {
    for (auto& s : sockets) keep->push_back(std::move(s));
  }
  return statuses;
}

// `connections` threads, each with its own context and one connection, each sending all of
// `batch` at once and reading the replies for up to `wait`: the statuses, summed.
std::map<std::string, int> FireFromThreads(const std::string& endpoint,
                                           const std::vector<std::string>& batch, int connections,
                                           std::chrono::seconds wait) {
  std::map<std::string, int> total;
  std::vector<std::thread> senders;
  Mutex mutex;  // guards total
  for (int c = 0; c < connections; ++c) {
    senders.emplace_back([&] {
      zmq::context_t own;
      auto s = Fire(own, endpoint, batch, true, true, wait);
      MutexLock lock(&mutex);
      for (auto& [k, v] : s) total[k] += v;
    });
  }
  for (auto& t : senders) t.join();
  return total;
}

std::string Localise(const std::string& jpeg) {
  v1::Request r;
  r.mutable_localise()->set_map("gp");
  r.mutable_localise()->set_jpeg(jpeg);
  return r.SerializeAsString();
}

namespace {

// `value` as a protobuf varint.
std::string Varint(uint64_t value) {
  std::string out;
  while (value >= 0x80) {
    out.push_back(static_cast<char>((value & 0x7f) | 0x80));
    value >>= 7;
  }
  out.push_back(static_cast<char>(value));
  return out;
}

// Field `field` of wire type 2 (length-delimited) holding `bytes`.
std::string Delimited(int field, const std::string& bytes) {
  return Varint(static_cast<uint64_t>(field) << 3 | 2) + Varint(bytes.size()) + bytes;
}

}  // namespace

std::string EmptyKeypoints(int keypoints, int width, int height) {
  v1::FeatureSet f;
  f.set_image_width(width);
  f.set_image_height(height);
  std::string features = f.SerializeAsString();
  features.reserve(features.size() + 2 * static_cast<size_t>(keypoints));
  for (int i = 0; i < keypoints; ++i) features += Delimited(3, "");  // FeatureSet.keypoints
  v1::LocaliseRequest localise;
  localise.set_map("gp");
  // LocaliseRequest.features (4) inside Request.localise (2).
  return Delimited(2, localise.SerializeAsString() + Delimited(4, features));
}

std::string Encode(const cv::Mat& image, bool progressive) {
  std::vector<uint8_t> out;
  cv::imencode(".jpg", image, out,
               {cv::IMWRITE_JPEG_PROGRESSIVE, progressive ? 1 : 0, cv::IMWRITE_JPEG_QUALITY, 80});
  return std::string(out.begin(), out.end());
}

// The JPEG with its last scan repeated `extra` times before the end-of-image marker.
std::string WithExtraScans(const std::string& jpeg, int extra) {
  const size_t sos = jpeg.rfind("\xff\xda");
  const size_t eoi = jpeg.rfind("\xff\xd9");
  const std::string scan = jpeg.substr(sos, eoi - sos);
  std::string out = jpeg.substr(0, eoi);
  for (int i = 0; i < extra; ++i) out += scan;
  return out + "\xff\xd9";
}

std::string Statuses(const std::map<std::string, int>& s) {
  std::string out;
  for (const auto& [k, v] : s) out += (out.empty() ? "" : " ") + k + "=" + std::to_string(v);
  return out.empty() ? "(not read)" : out;
}

}  // namespace sceneloc::hostile
