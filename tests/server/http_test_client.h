// A plain HTTP/1.1 client for tests of the server's operator endpoint: one request over a
// TCP socket, read to the end.
#pragma once

#include <string>

namespace sceneloc::test {

struct HttpResult {
  int status = 0;  // 0 when nothing answered (or the reply was not HTTP/1.1)
  std::string headers;
  std::string body;
};

// Sends `method` `path` to HOST:PORT (an IPv4 address) with "Connection: close" and reads
// the reply.
HttpResult Http(const std::string& address, const std::string& method, const std::string& path);

}  // namespace sceneloc::test
