#pragma once

// Starting a connection of HttpServer (internal to server/http): plain and TLS connections
// compile in separate files (connection_plain.cpp, connection_tls.cpp).

#include <boost/asio/ip/tcp.hpp>
#include <memory>
#include <string>

#include "server/http/connection_state.hpp"

namespace soilvol::server::http_detail {

/// Serves HTTP on `socket` until the client or the limits end it.
void StartPlainConnection(std::shared_ptr<Shared> shared, std::string peer,
                          boost::asio::ip::tcp::socket socket);
/// Serves HTTPS on `socket` with the TLS context for new connections.
void StartTlsConnection(std::shared_ptr<Shared> shared, std::string peer,
                        boost::asio::ip::tcp::socket socket);

}  // namespace soilvol::server::http_detail
