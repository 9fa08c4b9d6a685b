#include "server/http/connection.hpp"
#include "server/http/connection_impl.hpp"

namespace soilvol::server::http_detail {

void StartTlsConnection(std::shared_ptr<Shared> shared, std::string peer, tcp::socket socket) {
    std::shared_ptr<ssl::context> context = shared->tls->Current();
    auto connection = std::make_shared<Connection<TlsStream>>(std::move(shared), std::move(peer),
                                                              std::move(socket), *context);
    connection->KeepContext(std::move(context));
    connection->Start();
}

}  // namespace soilvol::server::http_detail
