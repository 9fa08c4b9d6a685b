#include "client/http_probe.hpp"

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <chrono>

namespace soilvol::client {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;

int HttpGet(const std::string& host_port, const std::string& path, double timeout_s,
            std::string* body, std::string* error) {
    const std::size_t colon = host_port.rfind(':');
    if (colon == std::string::npos || colon == 0) {
        *error = "'" + host_port + "' is not host:port";
        return -1;
    }
    std::string host = host_port.substr(0, colon);
    if (host.size() > 2 && host.front() == '[') host = host.substr(1, host.size() - 2);
    try {
        net::io_context io;
        beast::tcp_stream stream(io);
        stream.expires_after(std::chrono::milliseconds(static_cast<long long>(timeout_s * 1e3)));
        net::ip::tcp::resolver resolver(io);
        stream.connect(resolver.resolve(host, host_port.substr(colon + 1)));
        http::request<http::empty_body> request{http::verb::get, path, 11};
        request.set(http::field::host, host);
        http::write(stream, request);
        beast::flat_buffer buffer;
        http::response<http::string_body> response;
        http::read(stream, buffer, response);
        *body = response.body();
        beast::error_code ignored;
        stream.socket().shutdown(net::ip::tcp::socket::shutdown_both, ignored);
        return static_cast<int>(response.result_int());
    } catch (const std::exception& e) {
        *error = e.what();
        return -1;
    }
}

}  // namespace soilvol::client
