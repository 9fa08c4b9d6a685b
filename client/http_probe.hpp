#pragma once

#include <string>

namespace soilvol::client {

/// GET http://<host_port><path> over plain HTTP/1.1 within `timeout_s`: the status code, or -1
/// with `error` set when no answer came. For the server's probe listener (--probe-address),
/// which container health checks reach without certificates or tokens.
int HttpGet(const std::string& host_port, const std::string& path, double timeout_s,
            std::string* body, std::string* error);

}  // namespace soilvol::client
