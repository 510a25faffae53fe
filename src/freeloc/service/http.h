// The HTTP transport of `freeloc serve` (Boost.Beast over Boost.Asio): every request bounded before any handler runs.
// Headers: at most `header_bytes` (beyond: 431), read within `header_timeout_s` of the connection's turn (a client
// sending them a byte a second is closed, never holds a thread). Bodies: a declared Content-Length over the limit is
// answered 413 at once, before a byte is read (an `Expect: 100-continue` one is never invited); a chunked body is cut
// at the limit; the body must arrive within `body_timeout_s`. At most `max_connections` connections are open: one more
// is answered 503 and closed. Requests are read by a few event-loop threads; cheap routes (health, static files,
// listings) run there, heavy ones on a bounded pool of handler threads (full: 503 with Retry-After). Stop() closes the
// listener and every connection that is not being answered, and returns once the admitted requests are answered.
//
// The multipart/form-data body is parsed by freeloc (multipart.h), bounded in parts, names and part headers.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "freeloc/service/multipart.h"

namespace freeloc::service::http {

struct Request {
  std::string method, target, path, query, body;
  std::map<std::string, std::string> headers;  // names lower-case
  std::map<std::string, std::string> params;   // the query string, decoded
  std::vector<std::string> matches;            // the route's regex groups (matches[0]: the path)

  std::string get_header_value(const std::string& name) const;
  bool has_header(const std::string& name) const;
  bool has_param(const std::string& name) const { return params.count(name) > 0; }
  std::string get_param_value(const std::string& name) const;
  bool is_multipart_form_data() const;
  // The form fields (parsed on first use; a malformed body throws freeloc::Error).
  bool has_file(const std::string& name) const;
  const Part& get_file_value(const std::string& name) const;

 private:
  void Parse() const;
  mutable std::unique_ptr<std::map<std::string, Part>> form_;
};

struct Response {
  int status = 200;
  std::string body, content_type;
  std::vector<std::pair<std::string, std::string>> headers;
  void set_content(std::string content, const std::string& type) {
    body = std::move(content);
    content_type = type;
  }
  void set_header(const std::string& name, const std::string& value) { headers.emplace_back(name, value); }
};

using Handler = std::function<void(const Request&, Response&)>;

struct Limits {
  size_t header_bytes = 16 << 10;
  uint64_t body_bytes = 64ull << 20;
  double header_timeout_s = 10;  // from the connection's turn to the end of the headers
  double body_timeout_s = 120;   // from the end of the headers to the end of the body
  double write_timeout_s = 60;   // the response
  double keepalive_s = 5;        // an idle kept-alive connection
  int max_connections = 256;     // open at once; one more: 503, closed
  int handler_threads = 8;       // heavy routes at once; beyond: 503
  int io_threads = 2;            // event-loop threads
};

class Server {
 public:
  explicit Server(const Limits& limits);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // A route: `method` and an ECMAScript regex matched against the whole path. Heavy routes run on the handler pool.
  void Route(const std::string& method, const std::string& pattern, Handler handler, bool heavy = false);
  // The `{"error": …}` text of an answer the transport gives itself (400 malformed, 404 no route, 408, 413, 415, 431,
  // 503); `status` may be changed by it (a 413 for a body that is not multipart becomes 415).
  void SetErrorText(std::function<std::string(const Request&, int* status)> text);
  // Called after every answer, with its status (the metrics).
  void SetLogger(std::function<void(int status)> log);

  int Bind(const std::string& host, int port);  // 0: any free port; throws freeloc::Error
  void Serve();                                 // until Stop(): returns once the admitted requests are answered
  void Stop();

  struct Impl;  // (http.cc: the connections share it)

 private:
  std::shared_ptr<Impl> impl_;
};

}  // namespace freeloc::service::http
