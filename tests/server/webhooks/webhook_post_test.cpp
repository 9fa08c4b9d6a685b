#include "server/webhooks/webhook_post.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "tests/server/store/scratch_dir.hpp"
#include "tests/server/webhooks/loopback_http.hpp"

extern char** environ;

namespace soilvol::server {
namespace {

using std::chrono::milliseconds;
using SteadyClock = std::chrono::steady_clock;

using testing_http::LoopbackListener;
using testing_http::ReadHttpRequest;
using testing_http::Response;
using testing_http::ScriptedHttpServer;

WebhookUrl LoopbackUrl(int port, const std::string& target, bool tls = false,
                       const std::string& host = "127.0.0.1") {
    const absl::StatusOr<WebhookUrl> url =
        ParseWebhookUrl(absl::StrCat(tls ? "https://" : "http://", host, ":", port, target));
    EXPECT_TRUE(url.ok()) << url.status();
    return url.ok() ? *url : WebhookUrl{};
}

TEST(WebhookPost, ABodyAndItsHeadersArriveAsSent) {
    ScriptedHttpServer server(Response("200 OK", "accepted"));
    const std::string body = R"({"event":"estimate.created","volume_m3":12.5})";
    const PostResult result =
        PostJson(LoopbackUrl(server.port(), "/hooks/in?x=1"),
                 {{"X-Soilvol-Signature", "t=1,v1=ab"}, {"X-Soilvol-Event", "estimate.created"}},
                 body, PostOptions{});
    EXPECT_EQ(result.error, "");
    EXPECT_EQ(result.status_code, 200);
    EXPECT_EQ(result.body_excerpt, "accepted");
    EXPECT_GE(result.latency.count(), 0);
    EXPECT_LT(result.latency.count(), 2000);
    const std::vector<std::string> requests = server.requests();
    ASSERT_EQ(requests.size(), 1u);
    const std::string& request = requests[0];
    EXPECT_TRUE(absl::StartsWith(request, "POST /hooks/in?x=1 HTTP/1.1\r\n")) << request;
    for (const std::string& line :
         {absl::StrCat("Host: 127.0.0.1:", server.port()),
          std::string("User-Agent: soilvol-webhooks/1"),
          std::string("Content-Type: application/json"),
          absl::StrCat("Content-Length: ", body.size()), std::string("Connection: close"),
          std::string("X-Soilvol-Signature: t=1,v1=ab"),
          std::string("X-Soilvol-Event: estimate.created")}) {
        EXPECT_NE(request.find("\r\n" + line + "\r\n"), std::string::npos) << line;
    }
    EXPECT_TRUE(absl::EndsWith(request, "\r\n\r\n" + body)) << request;
}

TEST(WebhookPost, AServerErrorIsReportedAsItsStatus) {
    ScriptedHttpServer server(Response("500 Internal Server Error", "boom"));
    const PostResult result = PostJson(LoopbackUrl(server.port(), "/"), {}, "{}", PostOptions{});
    EXPECT_EQ(result.status_code, 500);
    EXPECT_EQ(result.error, "") << "a response came";
    EXPECT_EQ(result.body_excerpt, "boom");
}

TEST(WebhookPost, ARedirectIsReportedNotFollowed) {
    ScriptedHttpServer server(
        "HTTP/1.1 302 Found\r\nLocation: /elsewhere\r\n"
        "Content-Length: 0\r\n\r\n");
    const PostResult result = PostJson(LoopbackUrl(server.port(), "/"), {}, "{}", PostOptions{});
    EXPECT_EQ(result.status_code, 302);
    EXPECT_EQ(result.error, "");
    EXPECT_EQ(server.requests().size(), 1u);
}

TEST(WebhookPost, ASilentServerTimesOutWithinASecondOfTheTimeout) {
    LoopbackListener silent;  // the kernel completes the handshake; nobody ever reads
    PostOptions options;
    options.timeout = milliseconds(500);
    const auto start = SteadyClock::now();
    const PostResult result = PostJson(LoopbackUrl(silent.port(), "/"), {}, "{}", options);
    const auto elapsed = std::chrono::duration_cast<milliseconds>(SteadyClock::now() - start);
    EXPECT_EQ(result.error, "timeout after 500 ms");
    EXPECT_EQ(result.status_code, 0);
    EXPECT_GE(elapsed.count(), 480);
    EXPECT_LT(elapsed.count(), 1500);
    EXPECT_NEAR(static_cast<double>(result.latency.count()), static_cast<double>(elapsed.count()),
                50.0);
    // A TLS handshake that never gets an answer is bounded the same way.
    options.timeout = milliseconds(300);
    const PostResult tls = PostJson(LoopbackUrl(silent.port(), "/", true), {}, "{}", options);
    EXPECT_EQ(tls.error, "timeout after 300 ms");
    EXPECT_GE(tls.latency.count(), 280);
    EXPECT_LT(tls.latency.count(), 1300);
}

TEST(WebhookPost, ARefusedConnectionIsAConnectError) {
    int port = 0;
    {
        LoopbackListener closed;
        port = closed.port();
    }
    const PostResult result = PostJson(LoopbackUrl(port, "/"), {}, "{}", PostOptions{});
    EXPECT_TRUE(absl::StartsWith(result.error, "connect: ")) << result.error;
    EXPECT_EQ(result.status_code, 0);
    EXPECT_LT(result.latency.count(), 1000);
}

TEST(WebhookPost, AnOversizedBodyIsAnErrorThatKeepsTheStatus) {
    ScriptedHttpServer server(Response("200 OK", std::string(100000, 'x')));
    PostOptions options;
    options.max_response_bytes = 1000;
    const PostResult result = PostJson(LoopbackUrl(server.port(), "/"), {}, "{}", options);
    EXPECT_EQ(result.status_code, 200);
    EXPECT_EQ(result.error, "read: response body over 1000 bytes");
    EXPECT_LE(result.body_excerpt.size(), kBodyExcerptBytes);
}

TEST(WebhookPost, AnOversizedBodyOfUnknownLengthIsCappedToo) {
    ScriptedHttpServer server("HTTP/1.1 200 OK\r\nConnection: close\r\n\r\n" +
                              std::string(100000, 'y'));
    PostOptions options;
    options.max_response_bytes = 2000;
    const PostResult result = PostJson(LoopbackUrl(server.port(), "/"), {}, "{}", options);
    EXPECT_EQ(result.status_code, 200);
    EXPECT_EQ(result.error, "read: response body over 2000 bytes");
    EXPECT_LE(result.body_excerpt.size(), kBodyExcerptBytes);
    EXPECT_EQ(result.body_excerpt.find_first_not_of('y'), std::string::npos);
}

TEST(WebhookPost, AnOversizedChunkedBodyIsCappedToo) {
    std::string chunked = "HTTP/1.1 201 Created\r\nTransfer-Encoding: chunked\r\n\r\n";
    for (int i = 0; i < 10; ++i) chunked += "3e8\r\n" + std::string(1000, 'c') + "\r\n";
    ScriptedHttpServer server(chunked + "0\r\n\r\n");
    PostOptions options;
    options.max_response_bytes = 5000;
    const PostResult capped = PostJson(LoopbackUrl(server.port(), "/"), {}, "{}", options);
    EXPECT_EQ(capped.status_code, 201);
    EXPECT_EQ(capped.error, "read: response body over 5000 bytes");
    EXPECT_LE(capped.body_excerpt.size(), kBodyExcerptBytes);
    options.max_response_bytes = 10000;
    const PostResult whole = PostJson(LoopbackUrl(server.port(), "/"), {}, "{}", options);
    EXPECT_EQ(whole.status_code, 201);
    EXPECT_EQ(whole.error, "") << "exactly at the limit";
    EXPECT_EQ(whole.body_excerpt, std::string(kBodyExcerptBytes, 'c'));
}

TEST(WebhookPost, ALongBodyWithinTheLimitIsExcerpted) {
    std::string body;
    for (int i = 0; i < 100; ++i) absl::StrAppend(&body, i, ",");
    body.resize(600, 'z');
    ScriptedHttpServer server(Response("400 Bad Request", body));
    const PostResult result = PostJson(LoopbackUrl(server.port(), "/"), {}, "{}", PostOptions{});
    EXPECT_EQ(result.status_code, 400);
    EXPECT_EQ(result.error, "");
    EXPECT_EQ(result.body_excerpt, body.substr(0, kBodyExcerptBytes));
}

TEST(WebhookPost, HeadersThatWouldSplitOrReframeTheRequestAreRefusedUnsent) {
    ScriptedHttpServer server(Response("200 OK", ""));
    const WebhookUrl url = LoopbackUrl(server.port(), "/");
    const std::vector<std::pair<std::string, std::string>> refused[] = {
        {{"X-Event", "a\r\nX-Injected: 1"}},
        {{"X-Event", std::string("a\0b", 3)}},
        {{"X Event", "a"}},
        {{"", "a"}},
        {{"content-length", "0"}},
        {{"Host", "evil.example"}},
        {{"Transfer-Encoding", "chunked"}},
    };
    for (const auto& headers : refused) {
        SCOPED_TRACE(headers[0].first);
        const PostResult result = PostJson(url, headers, "{}", PostOptions{});
        EXPECT_TRUE(absl::StartsWith(result.error, "header: ")) << result.error;
        EXPECT_EQ(result.status_code, 0);
    }
    EXPECT_TRUE(server.requests().empty());
}

TEST(WebhookPost, ConcurrentCallsEachGetTheirAnswer) {
    ScriptedHttpServer server(Response("202 Accepted", "ok"));
    const WebhookUrl url = LoopbackUrl(server.port(), "/");
    std::vector<PostResult> results(8);
    std::vector<std::thread> threads;
    for (PostResult& result : results) {
        threads.emplace_back([&url, &result] { result = PostJson(url, {}, "{}", PostOptions{}); });
    }
    for (std::thread& thread : threads) thread.join();
    for (const PostResult& result : results) {
        EXPECT_EQ(result.status_code, 202) << result.error;
        EXPECT_EQ(result.body_excerpt, "ok");
    }
    EXPECT_EQ(server.requests().size(), results.size());
}

// An HTTPS server in python3 (ssl, http.server) on 127.0.0.1 that answers 200 to a POST.
constexpr const char* kHttpsServerScript = R"(
import http.server, ssl, sys
class Handler(http.server.BaseHTTPRequestHandler):
    def do_POST(self):
        self.rfile.read(int(self.headers.get("Content-Length", "0")))
        body = b'{"ok":true}'
        self.send_response(200)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)
    def log_message(self, *args):
        pass
server = http.server.HTTPServer(("127.0.0.1", 0), Handler)
context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
context.load_cert_chain(sys.argv[1], sys.argv[2])
server.socket = context.wrap_socket(server.socket, server_side=True)
print(server.server_address[1], flush=True)
server.serve_forever()
)";

// The script above as a child process; its port is the first line it prints.
class PythonHttpsServer {
  public:
    PythonHttpsServer(const std::string& cert, const std::string& key) {
        int out[2];
        if (::pipe(out) != 0) return;
        posix_spawn_file_actions_t actions;
        posix_spawn_file_actions_init(&actions);
        posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
        posix_spawn_file_actions_addclose(&actions, out[0]);
        std::vector<std::string> args = {"python3", "-c", kHttpsServerScript, cert, key};
        std::vector<char*> argv;
        for (std::string& arg : args) argv.push_back(arg.data());
        argv.push_back(nullptr);
        if (::posix_spawnp(&pid_, "python3", &actions, nullptr, argv.data(), environ) != 0) {
            pid_ = -1;
        }
        posix_spawn_file_actions_destroy(&actions);
        ::close(out[1]);
        port_ = ReadPort(out[0]);
        ::close(out[0]);
    }
    ~PythonHttpsServer() {
        if (pid_ <= 0) return;
        ::kill(pid_, SIGTERM);
        ::waitpid(pid_, nullptr, 0);
    }
    PythonHttpsServer(const PythonHttpsServer&) = delete;
    PythonHttpsServer& operator=(const PythonHttpsServer&) = delete;

    int port() const { return port_; }

  private:
    // The first line of `fd` as a port, within 10 s; 0 when none came.
    static int ReadPort(int fd) {
        std::string line;
        pollfd wait{fd, POLLIN, 0};
        char c = 0;
        while (::poll(&wait, 1, 10000) == 1 && ::read(fd, &c, 1) == 1 && c != '\n') line += c;
        return line.empty() ? 0 : std::atoi(line.c_str());
    }

    pid_t pid_ = -1;
    int port_ = 0;
};

// A self-signed certificate for DNS:localhost, made once for the suite, and the server.
class WebhookPostTls : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        dir_ = new ScratchDir();
        cert_ = (dir_->path() / "cert.pem").string();
        key_ = (dir_->path() / "key.pem").string();
        const std::string command =
            absl::StrCat("openssl req -x509 -newkey rsa:2048 -nodes -subj /CN=localhost ",
                         "-addext subjectAltName=DNS:localhost -days 1 -keyout ", key_, " -out ",
                         cert_, " 2>/dev/null");
        made_ = std::system(command.c_str()) == 0;
    }
    static void TearDownTestSuite() {
        delete dir_;
        dir_ = nullptr;
    }
    void SetUp() override {
        ASSERT_TRUE(made_) << "openssl req failed";
        server_ = std::make_unique<PythonHttpsServer>(cert_, key_);
        ASSERT_GT(server_->port(), 0) << "the python3 HTTPS server did not start";
    }
    PostResult Post(const std::string& host, const std::string& ca_file) {
        PostOptions options;
        options.ca_file = ca_file;
        return PostJson(LoopbackUrl(server_->port(), "/hook", true, host), {}, R"({"a":1})",
                        options);
    }

    static inline ScratchDir* dir_ = nullptr;
    static inline std::string cert_;
    static inline std::string key_;
    static inline bool made_ = false;
    std::unique_ptr<PythonHttpsServer> server_;
};

TEST_F(WebhookPostTls, TheServersCertificateAsCaIsTrusted) {
    const PostResult result = Post("localhost", cert_);
    EXPECT_EQ(result.error, "");
    EXPECT_EQ(result.status_code, 200);
    EXPECT_EQ(result.body_excerpt, R"({"ok":true})");
}

TEST_F(WebhookPostTls, ASelfSignedCertificateIsRefusedByTheSystemsCas) {
    const PostResult result = Post("localhost", "");
    EXPECT_EQ(result.error, "tls: certificate verify failed: self-signed certificate");
    EXPECT_EQ(result.status_code, 0);
}

TEST_F(WebhookPostTls, AHostTheCertificateDoesNotNameIsRefused) {
    const PostResult result = Post("127.0.0.1", cert_);  // the certificate names localhost only
    EXPECT_EQ(result.error, "tls: certificate verify failed: IP address mismatch");
    EXPECT_EQ(result.status_code, 0);
    // The same server and CA pass under the name the certificate has (the check is the name).
    EXPECT_EQ(Post("localhost", cert_).status_code, 200);
}

TEST_F(WebhookPostTls, AMissingOrBrokenCaFileIsATlsError) {
    const PostResult result = Post("localhost", cert_ + ".missing");
    EXPECT_EQ(result.error,
              absl::StrCat("tls: cannot read ", cert_, ".missing: No such file or directory"));
    EXPECT_EQ(result.status_code, 0);
    const std::string garbage = (dir_->path() / "garbage.pem").string();
    std::FILE* file = std::fopen(garbage.c_str(), "w");
    ASSERT_NE(file, nullptr);
    std::fputs("-----BEGIN CERTIFICATE-----\nnot base64\n-----END CERTIFICATE-----\n", file);
    std::fclose(file);
    const PostResult unreadable = Post("localhost", garbage);
    EXPECT_TRUE(absl::StartsWith(unreadable.error, "tls: cannot load " + garbage + ": "))
        << unreadable.error;
    EXPECT_EQ(unreadable.error.find("asio.ssl error"), std::string::npos) << unreadable.error;
    EXPECT_EQ(result.status_code, 0);
}

}  // namespace
}  // namespace soilvol::server
