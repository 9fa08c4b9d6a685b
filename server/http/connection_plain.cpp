#include "server/http/connection.hpp"
#include "server/http/connection_impl.hpp"

namespace soilvol::server::http_detail {

void StartPlainConnection(std::shared_ptr<Shared> shared, std::string peer, tcp::socket socket) {
    std::make_shared<Connection<PlainStream>>(std::move(shared), std::move(peer), std::move(socket))
        ->Start();
}

}  // namespace soilvol::server::http_detail
