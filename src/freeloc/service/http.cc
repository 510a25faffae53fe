#include "freeloc/service/http.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <chrono>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <regex>
#include <set>
#include <thread>

#include "freeloc/core/error.h"
#include "freeloc/service/job_threads.h"
#include "freeloc/service/multipart.h"

namespace freeloc::service::http {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace bhttp = boost::beast::http;
using tcp = net::ip::tcp;

// ---------------------------------------------------------------------------------------------------------------------
// Requests

namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

int Hex(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::string Decode(const std::string& s, bool plus) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && Hex(s[i + 1]) >= 0 && Hex(s[i + 2]) >= 0) {
      out += static_cast<char>(Hex(s[i + 1]) * 16 + Hex(s[i + 2]));
      i += 2;
    } else {
      out += plus && s[i] == '+' ? ' ' : s[i];
    }
  }
  return out;
}

}  // namespace

std::string Request::get_header_value(const std::string& name) const {
  const auto it = headers.find(Lower(name));
  return it == headers.end() ? std::string() : it->second;
}
bool Request::has_header(const std::string& name) const { return headers.count(Lower(name)) > 0; }
std::string Request::get_param_value(const std::string& name) const {
  const auto it = params.find(name);
  return it == params.end() ? std::string() : it->second;
}
bool Request::is_multipart_form_data() const {
  return Lower(get_header_value("Content-Type")).rfind("multipart/form-data", 0) == 0;
}
void Request::Parse() const {
  if (!form_)
    form_ = std::make_unique<std::map<std::string, Part>>(ParseMultipart(body, get_header_value("Content-Type")));
}
bool Request::has_file(const std::string& name) const {
  Parse();
  return form_->count(name) > 0;
}
const Part& Request::get_file_value(const std::string& name) const {
  Parse();
  return form_->at(name);
}

// ---------------------------------------------------------------------------------------------------------------------
// The server

namespace {

struct RouteEntry {
  std::string method;
  std::regex pattern;
  Handler handler;
  bool heavy;
};

class Session;

}  // namespace

struct Server::Impl : std::enable_shared_from_this<Server::Impl> {
  Limits limits;
  net::io_context io;
  tcp::acceptor acceptor{io};
  std::vector<RouteEntry> routes;
  std::function<std::string(const Request&, int*)> error_text;
  std::function<void(int)> logger;
  std::unique_ptr<JobThreads> pool;
  std::atomic<bool> stopping{false};
  std::mutex sessions_mu;
  std::set<Session*> sessions;  // the open connections (their count is the connection limit's)

  explicit Impl(const Limits& l) : limits(l), pool(std::make_unique<JobThreads>(l.handler_threads)) {}
  void Accept();
  void CloseIdle();
};

namespace {

std::chrono::steady_clock::duration Seconds(double s) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(s));
}

class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(tcp::socket socket, std::shared_ptr<Server::Impl> server)
      : stream_(std::move(socket)), server_(std::move(server)) {
    std::lock_guard<std::mutex> lock(server_->sessions_mu);
    server_->sessions.insert(this);
  }
  ~Session() {
    std::lock_guard<std::mutex> lock(server_->sessions_mu);
    server_->sessions.erase(this);
  }
  void Start() { ReadHeader(); }
  // Stop(): a connection waiting for (or reading) a request is closed; one being answered finishes first.
  void CloseIfIdle() {
    auto self = weak_from_this().lock();  // (null while its destructor waits for the session list: nothing to close)
    if (!self) return;
    net::post(stream_.get_executor(), [self] {
      if (!self->answering_) self->stream_.socket().close();
    });
  }

 private:
  void ReadHeader() {
    if (server_->stopping) return Close();
    head_ = false;
    parser_.emplace();
    parser_->header_limit(static_cast<std::uint32_t>(server_->limits.header_bytes));
    parser_->body_limit(server_->limits.body_bytes);
    stream_.expires_after(Seconds(first_ ? server_->limits.header_timeout_s
                                         : std::min(server_->limits.header_timeout_s, server_->limits.keepalive_s)));
    first_ = false;
    bhttp::async_read_header(stream_, buffer_, *parser_,
                             [self = shared_from_this()](beast::error_code ec, size_t) { self->OnHeader(ec); });
  }

  void FillRequest() {
    const auto& m = parser_->get();
    req_ = Request();
    req_.method = std::string(m.method_string());
    req_.target = std::string(m.target());
    const size_t q = req_.target.find('?');
    req_.path = Decode(req_.target.substr(0, q), false);
    req_.query = q == std::string::npos ? "" : req_.target.substr(q + 1);
    for (const auto& f : m) {
      std::string& v = req_.headers[Lower(std::string(f.name_string()))];
      v = v.empty() ? std::string(f.value()) : v + ", " + std::string(f.value());
    }
    std::string rest = req_.query;
    while (!rest.empty() && req_.params.size() < 64) {
      const size_t amp = rest.find('&');
      const std::string kv = rest.substr(0, amp);
      const size_t eq = kv.find('=');
      if (!kv.empty())
        req_.params[Decode(kv.substr(0, eq), true)] = eq == std::string::npos ? "" : Decode(kv.substr(eq + 1), true);
      rest = amp == std::string::npos ? "" : rest.substr(amp + 1);
    }
  }

  void OnHeader(beast::error_code ec) {
    if (ec) {
      // A closed or idle connection, a client too slow with its headers (the stream's timer closed the socket):
      // closed without an answer. Malformed or oversized headers: 400 / 431.
      if (ec == bhttp::error::header_limit) return Fail(431);
      if (ec == bhttp::error::body_limit) {  // a declared Content-Length over the limit: refused unread
        FillRequestSafe();
        return Fail(413);
      }
      if (ec == bhttp::error::end_of_stream || ec == beast::error::timeout || ec == net::error::operation_aborted ||
          ec == net::error::eof || ec == net::error::connection_reset || ec == net::error::bad_descriptor)
        return Close();
      return Fail(400);
    }
    FillRequest();
    const auto length = parser_->content_length();
    if (length && *length > server_->limits.body_bytes) return Fail(413);  // before a byte of it is read
    if (Lower(req_.get_header_value("Expect")) == "100-continue") {
      auto cont = std::make_shared<std::string>("HTTP/1.1 100 Continue\r\n\r\n");
      stream_.expires_after(Seconds(server_->limits.write_timeout_s));
      net::async_write(stream_, net::buffer(*cont), [self = shared_from_this(), cont](beast::error_code e, size_t) {
        if (e) return self->Close();
        self->ReadBody();
      });
      return;
    }
    ReadBody();
  }

  void ReadBody() {
    stream_.expires_after(Seconds(server_->limits.body_timeout_s));
    bhttp::async_read(stream_, buffer_, *parser_, [self = shared_from_this()](beast::error_code ec, size_t) {
      if (ec == bhttp::error::body_limit) return self->Fail(413);
      if (ec == beast::error::timeout) return self->Close();  // (the timer closed the socket: no answer can go)
      if (ec == bhttp::error::end_of_stream || ec == net::error::eof || ec == net::error::connection_reset ||
          ec == net::error::operation_aborted || ec == net::error::bad_descriptor)
        return self->Close();
      if (ec) return self->Fail(400);
      self->req_.body = std::move(self->parser_->get().body());
      self->Dispatch();
    });
  }

  void Dispatch() {
    keep_alive_ = parser_->get().keep_alive();
    head_ = req_.method == "HEAD";  // a GET route's headers without its body (monitors, curl -I)
    for (const RouteEntry& r : server_->routes) {
      std::smatch m;
      if (r.method != (head_ ? std::string("GET") : req_.method) || !std::regex_match(req_.path, m, r.pattern))
        continue;
      req_.matches.assign(m.begin(), m.end());
      answering_ = true;
      if (!r.heavy) {
        Response res;
        Run(r.handler, res);
        return Write(std::move(res));
      }
      // The handler thread answers; the io_context is kept running for it (the work guard) until it hands back.
      auto guard =
          std::make_shared<net::executor_work_guard<net::io_context::executor_type>>(server_->io.get_executor());
      const Handler* h = &r.handler;
      if (!server_->pool->TryPost([self = shared_from_this(), h, guard] {
            Response res;
            self->Run(*h, res);
            net::post(self->stream_.get_executor(),
                      [self, res = std::move(res), guard]() mutable { self->Write(std::move(res)); });
          })) {
        return Fail(503);
      }
      return;
    }
    Fail(404);
  }

  void Run(const Handler& h, Response& res) {
    try {
      h(req_, res);
    } catch (const Error& e) {
      res = Response();
      res.status = 400;
      res.set_content(std::string("{\"error\":") + Quote(e.what()) + "}", "application/json");
    } catch (const std::exception& e) {
      res = Response();
      res.status = 500;
      res.set_content(std::string("{\"error\":") + Quote(std::string("internal error: ") + e.what()) + "}",
                      "application/json");
    }
  }

  // A message as a JSON string, bytes that are not UTF-8 replaced (as server.cc's SendJson writes its answers).
  static std::string Quote(const std::string& s) {
    return nlohmann::json(SafeText(s, 2000)).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  }

  // An answer the transport gives itself; the connection is closed after it (the rest of the request is unread).
  void Fail(int status) {
    keep_alive_ = false;
    failed_ = true;
    answering_ = true;
    if (req_.method.empty() && parser_) FillRequestSafe();
    Response res;
    res.status = status;
    std::string text = server_->error_text ? server_->error_text(req_, &res.status) : "HTTP error";
    if (status == 503) res.set_header("Retry-After", "1");
    res.set_content("{\"error\":" + Quote(text) + "}", "application/json");
    Write(std::move(res));
  }

  void FillRequestSafe() {
    try {
      FillRequest();
    } catch (...) {
    }
  }

  void Write(Response res) {
    auto msg = std::make_shared<bhttp::response<bhttp::string_body>>();
    msg->version(11);
    msg->result(static_cast<unsigned>(res.status));
    if (!res.content_type.empty()) msg->set(bhttp::field::content_type, res.content_type);
    for (const auto& [k, v] : res.headers) msg->set(k, v);
    msg->set(bhttp::field::server, "freeloc");
    const bool keep = keep_alive_ && !server_->stopping;
    msg->keep_alive(keep);
    if (res.status != 304) msg->body() = std::move(res.body);
    msg->prepare_payload();
    if (head_) msg->body().clear();  // Content-Length stays that of the GET answer
    if (server_->logger) server_->logger(res.status);
    stream_.expires_after(Seconds(server_->limits.write_timeout_s));
    bhttp::async_write(stream_, *msg, [self = shared_from_this(), msg, keep](beast::error_code ec, size_t) {
      self->answering_ = false;
      if (!ec && self->failed_) return self->LingerClose();
      if (ec || !keep) return self->Close();
      self->req_ = Request();
      self->ReadHeader();
    });
  }

  // After an answer given before the request was read in full (413, 408, 400): the sending side is closed, and what
  // the client still sends is read and dropped for up to 2 s and 8 MB, so that it reads the answer instead of a reset.
  void LingerClose() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
    stream_.expires_after(std::chrono::seconds(2));
    Drain(std::make_shared<std::array<char, 65536>>(), 0);
  }
  void Drain(std::shared_ptr<std::array<char, 65536>> buf, size_t total) {
    stream_.async_read_some(net::buffer(*buf), [self = shared_from_this(), buf, total](beast::error_code ec, size_t n) {
      if (ec || total + n > (8u << 20)) return self->Close();
      self->Drain(buf, total + n);
    });
  }

  void Close() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
    stream_.socket().close(ec);
  }

  beast::tcp_stream stream_;
  std::shared_ptr<Server::Impl> server_;
  beast::flat_buffer buffer_;
  std::optional<bhttp::request_parser<bhttp::string_body>> parser_;
  Request req_;
  bool keep_alive_ = false, first_ = true, failed_ = false, head_ = false;
  std::atomic<bool> answering_{false};
};

}  // namespace

void Server::Impl::Accept() {
  acceptor.async_accept(net::make_strand(io), [self = shared_from_this()](beast::error_code ec, tcp::socket socket) {
    if (ec) {
      if (!self->stopping && ec != net::error::operation_aborted) self->Accept();
      return;
    }
    size_t open = 0;
    {
      std::lock_guard<std::mutex> lock(self->sessions_mu);
      open = self->sessions.size();
    }
    if (open >= static_cast<size_t>(self->limits.max_connections)) {
      // Over the connection limit: a short 503, then closed (it never waits unread, holding a slot).
      auto s = std::make_shared<tcp::socket>(std::move(socket));
      const std::string body = "{\"error\":\"busy: too many open connections; retry later\"}";
      auto text = std::make_shared<std::string>(
          "HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/json\r\nRetry-After: 1\r\nConnection: "
          "close\r\nContent-Length: " +
          std::to_string(body.size()) + "\r\n\r\n" + body);
      if (self->logger) self->logger(503);
      net::async_write(*s, net::buffer(*text), [s, text](beast::error_code, size_t) {
        beast::error_code e;
        s->shutdown(tcp::socket::shutdown_both, e);
        s->close(e);
      });
    } else {
      std::make_shared<Session>(std::move(socket), self)->Start();
    }
    if (!self->stopping) self->Accept();
  });
}

void Server::Impl::CloseIdle() {
  std::lock_guard<std::mutex> lock(sessions_mu);
  for (Session* s : sessions) s->CloseIfIdle();
}

Server::Server(const Limits& limits) : impl_(std::make_shared<Impl>(limits)) {}

Server::~Server() {
  Stop();
  impl_->io.stop();
  impl_->pool.reset();  // joins the handler threads
}

void Server::Route(const std::string& method, const std::string& pattern, Handler handler, bool heavy) {
  impl_->routes.push_back({method, std::regex(pattern), std::move(handler), heavy});
}

void Server::SetErrorText(std::function<std::string(const Request&, int*)> text) {
  impl_->error_text = std::move(text);
}
void Server::SetLogger(std::function<void(int)> log) { impl_->logger = std::move(log); }

int Server::Bind(const std::string& host, int port) {
  beast::error_code ec;
  tcp::endpoint ep(net::ip::make_address(host, ec), static_cast<unsigned short>(port));
  if (ec) {  // a name (localhost, a host name of this machine): its first address
    tcp::resolver resolver(impl_->io);
    const auto found = resolver.resolve(host, std::to_string(port), ec);
    FREELOC_CHECK(!ec && !found.empty(), host << ": not an address or a name of this machine (" << ec.message()
                                              << "); use 127.0.0.1, 0.0.0.0 or ::");
    ep = found.begin()->endpoint();
    ec.clear();
  }
  impl_->acceptor.open(ep.protocol(), ec);
  if (!ec) impl_->acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) impl_->acceptor.bind(ep, ec);
  if (!ec) impl_->acceptor.listen(net::socket_base::max_listen_connections, ec);
  FREELOC_CHECK(!ec, host << ":" << port << ": cannot bind (" << ec.message()
                          << "); choose another port, or an address of this machine");
  return impl_->acceptor.local_endpoint().port();
}

void Server::Serve() {
  impl_->Accept();
  std::vector<std::thread> extra;
  for (int i = 1; i < impl_->limits.io_threads; ++i) extra.emplace_back([this] { impl_->io.run(); });
  impl_->io.run();
  for (auto& t : extra) t.join();
}

void Server::Stop() {
  if (impl_->stopping.exchange(true)) return;
  net::post(impl_->io, [impl = impl_] {
    beast::error_code ec;
    impl->acceptor.close(ec);
    impl->CloseIdle();
  });
}

}  // namespace freeloc::service::http
