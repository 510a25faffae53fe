// `freeloc serve` (docs/service.md): the relocalization pipeline as an HTTP service (cpp-httplib) with a web page.
// Anchors (anchor_store.h) are kept warm; a query costs the query's work only. The work is admitted through a
// bounded queue (at most `workers` requests work at once, `max_queue` more wait; beyond that 503 at once), uploads
// are bounded (413), every request has a time limit, and Stop() finishes the admitted work before returning.
#pragma once

#include <memory>
#include <string>

#include "freeloc/eval/view3d.h"
#include "freeloc/pipeline/options.h"

namespace freeloc::service {

struct ServiceOptions {
  pipeline::PipelineOptions pipeline;  // the preset and overrides every anchor and query runs with
  std::string host = "127.0.0.1";
  int port = 8080;     // 0: any free port (Server::port() says which)
  int workers = 1;     // requests doing work at once (each runs the networks with the pipeline's threads)
  int max_queue = 64;  // requests waiting for a worker; more are answered 503
  int max_upload_mb = 64;
  int max_upload_mp = 50;  // megapixels a photo may declare (a 48 MP phone photo passes; a 0.5 MB PNG of 13000² not)
  int max_anchors = 1000;
  std::string token;                           // non-empty: every /v1 request needs "Authorization: Bearer <token>"
  std::string store_dir;                       // non-empty: anchors persisted there and reloaded at start
  double queue_timeout_s = 120;                // a request waiting longer for a worker is answered 503
  std::string static_dir = eval::kThreeJsDir;  // three.js (libjs-three) for the page's 3D view
  // The transport's bounds (service/http.h): a client's headers must arrive within header_timeout_s, its body within
  // body_timeout_s; at most max_connections are open.
  double header_timeout_s = 10, body_timeout_s = 120;
  int max_connections = 256;
  void Validate() const;
};

class Server {
 public:
  explicit Server(const ServiceOptions& options);  // loads the networks and the stored anchors
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds to host:port (throws freeloc::Error when it cannot); returns the port.
  int Bind();
  // Serves until Stop(); returns when the last admitted request has been answered.
  void Serve();
  void Stop();
  int port() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace freeloc::service
