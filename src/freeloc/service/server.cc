#include "freeloc/service/server.h"

#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/timing.h"
#include "freeloc/eval/run_report.h"
#include "freeloc/eval/view3d.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/image_io.h"
#include "freeloc/pipeline/record.h"
#include "freeloc/pipeline/relocalizer.h"
#include "freeloc/service/anchor_store.h"
#include "freeloc/service/http.h"
#include "freeloc/service/job_threads.h"
#include "freeloc/service/page.h"

namespace freeloc::service {

using Json = nlohmann::json;

namespace {

// At most `workers` requests work at once and `max_queue` wait; Enter() refuses at once beyond that, and after
// `timeout` of waiting.
class Admission {
 public:
  Admission(int workers, int max_queue) : workers_(workers), max_queue_(max_queue) {}
  bool Enter(double timeout_s) {
    std::unique_lock<std::mutex> lock(mu_);
    if (running_ + waiting_ >= workers_ + max_queue_) return false;
    ++waiting_;
    const bool got = cv_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] { return running_ < workers_; });
    --waiting_;
    if (!got) return false;
    ++running_;
    return true;
  }
  void Leave() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      --running_;
    }
    cv_.notify_one();
  }
  int running() const {
    std::lock_guard<std::mutex> lock(mu_);
    return running_;
  }
  int waiting() const {
    std::lock_guard<std::mutex> lock(mu_);
    return waiting_;
  }

 private:
  int workers_, max_queue_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  int running_ = 0, waiting_ = 0;
};

// Requests and errors of every route, and the latency of the last 4096 requests that did work.
class Metrics {
 public:
  // Every answered request, by its status (the server's logger calls this once per request).
  void Count(int status) {
    std::lock_guard<std::mutex> lock(mu_);
    ++requests_;
    if (status >= 400) ++errors_[status];
  }
  // The latency of a request that did work (adding an anchor, a relocalization).
  void Latency(double ms) {
    std::lock_guard<std::mutex> lock(mu_);
    latencies_.push_back(ms);
    if (latencies_.size() > 4096) latencies_.pop_front();
  }
  Json ToJson() const {
    std::lock_guard<std::mutex> lock(mu_);
    std::vector<double> v(latencies_.begin(), latencies_.end());
    std::sort(v.begin(), v.end());
    const auto q = [&](double p) {
      return v.empty() ? 0.0 : v[std::min(v.size() - 1, static_cast<size_t>(std::floor(p * (v.size() - 1) + 0.5)))];
    };
    Json errors = Json::object();
    for (const auto& [s, n] : errors_) errors[std::to_string(s)] = n;
    return {{"requests", requests_},
            {"errors", errors},
            {"latency_ms", {{"p50", q(0.5)}, {"p95", q(0.95)}, {"p99", q(0.99)}, {"window", v.size()}}}};
  }

 private:
  mutable std::mutex mu_;
  long long requests_ = 0;
  std::map<int, long long> errors_;
  std::deque<double> latencies_;
};

// VmRSS / VmHWM of this process in MiB (0 where /proc is not there).
double ProcMiB(const char* key) {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind(key, 0) == 0) return std::atof(line.c_str() + std::strlen(key)) / 1024.0;
  return 0;
}

void SendJson(http::Response& res, int status, const Json& j) {
  res.status = status;
  // Client text echoed in a message may hold bytes that are not UTF-8: replaced, never thrown (a throw here, on the
  // error path, would end the server).
  res.set_content(j.dump(-1, ' ', false, Json::error_handler_t::replace), "application/json");
}

const char* kMultipartExpected =
    "request: expected multipart/form-data with the fields 'image' (the photo), optional 'depth' (16-bit PNG, "
    "millimetres unless 'depth_unit' says cm or m) and 'intrinsics' (fx,fy,cx,cy); got ";

std::string ContentTypeText(const http::Request& req) {
  const std::string ct = req.get_header_value("Content-Type");
  return ct.empty() ? "no Content-Type" : "'" + SafeText(ct, 80) + "'";
}

void SendError(http::Response& res, int status, const std::string& message);

// 415 for a body that is not multipart/form-data (a photo posted raw, JSON, a form): true when answered.
bool NotMultipart(const http::Request& req, http::Response& res) {
  if (req.is_multipart_form_data()) return false;
  SendError(res, 415, kMultipartExpected + ContentTypeText(req));
  return true;
}

void SendError(http::Response& res, int status, const std::string& message) {
  SendJson(res, status, {{"error", message}});
}

// Compares a client's secret with the server's in time that depends on neither's contents (a byte-by-byte early exit
// would tell an attacker how much of a guess is right).
bool SameSecret(const std::string& given, const std::string& secret) {
  unsigned char diff = given.size() == secret.size() ? 0 : 1;
  for (size_t i = 0; i < secret.size(); ++i)
    diff |= static_cast<unsigned char>(secret[i] ^ (i < given.size() ? given[i] : 0));
  return diff == 0;
}

// The one answer for an id no anchor has (any text: ids are looked up, never turned into paths).
void SendUnknownAnchor(http::Response& res, const std::string& id) {
  SendError(res, 404,
            "anchor '" + SafeText(id, 40) +
                "': unknown (deleted, never added, or lost at a restart of a server without a store); GET "
                "/v1/anchors lists the anchors, POST /v1/anchors adds one");
}

// The photo fields of a multipart request; throws freeloc::Error (→ 400) naming what is wrong. (A body that is not
// multipart is answered 415 before: NotMultipart.)
PhotoUpload UploadOf(const http::Request& req) {
  FREELOC_CHECK(req.is_multipart_form_data(), kMultipartExpected << ContentTypeText(req));
  FREELOC_CHECK(req.has_file("image"), "image: missing; send the photo as the multipart field 'image'");
  PhotoUpload u;
  const std::string& img = req.get_file_value("image").content;
  u.image.assign(img.begin(), img.end());
  if (req.has_file("depth")) {
    const std::string& d = req.get_file_value("depth").content;
    u.depth.assign(d.begin(), d.end());
  }
  if (req.has_file("intrinsics")) u.intrinsics = req.get_file_value("intrinsics").content;
  FREELOC_CHECK(u.intrinsics.size() <= 200, "intrinsics: " << u.intrinsics.size() << " bytes; expected fx,fy,cx,cy");
  if (req.has_file("depth_unit")) u.depth_unit = req.get_file_value("depth_unit").content;
  FREELOC_CHECK(u.depth_unit.size() <= 8, "depth_unit: " << u.depth_unit.size() << " bytes; expected mm, cm or m");
  return u;
}

Json IntrinsicsJson(const pipeline::FrameIntrinsics& f) {
  return {{"fx", f.camera.fx},
          {"fy", f.camera.fy},
          {"cx", f.camera.cx},
          {"cy", f.camera.cy},
          {"source", ToString(f.source)}};
}

Json AnchorJson(const Anchor& a) {
  return {{"id", a.id},
          {"width", a.image.width},
          {"height", a.image.height},
          {"depth", a.has_depth},
          {"intrinsics", IntrinsicsJson(a.intrinsics)},
          {"reference_ms", a.reference_ms}};
}

std::string Base64(const std::vector<uint8_t>& b) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((b.size() + 2) / 3 * 4);
  for (size_t i = 0; i < b.size(); i += 3) {
    const uint32_t v = (uint32_t{b[i]} << 16) | (i + 1 < b.size() ? uint32_t{b[i + 1]} << 8 : 0) |
                       (i + 2 < b.size() ? uint32_t{b[i + 2]} : 0);
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += i + 1 < b.size() ? t[(v >> 6) & 63] : '=';
    out += i + 2 < b.size() ? t[v & 63] : '=';
  }
  return out;
}

// A depth map as a JPEG for the page, coloured as the report colours it.
std::vector<uint8_t> DepthPicture(const DepthMap& d) {
  return io::EncodeJpeg(eval::DepthColourImage(d), 85, "depth picture");
}

// A static file's text, "" when it is not there (three.js is optional for the API).
std::string ReadStatic(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return "";
  const std::vector<uint8_t> b = io::ReadFileBytes(path);
  return std::string(b.begin(), b.end());
}

// A static file served as a browser expects: gzip-compressed once here (not per request: three.min.js is 850 KB,
// 1.2–1.6 s of brotli per page load before), an ETag from its bytes, cached for a day; "" bytes when absent.
struct StaticAsset {
  std::string raw, gzip, etag;
  StaticAsset() = default;
  explicit StaticAsset(std::string bytes) : raw(std::move(bytes)) {
    if (raw.empty()) return;
    etag = "\"" + std::to_string(std::hash<std::string>()(raw)) + "-" + std::to_string(raw.size()) + "\"";
    z_stream z{};
    if (deflateInit2(&z, 9, Z_DEFLATED, 15 + 16, 9, Z_DEFAULT_STRATEGY) != Z_OK) return;  // +16: a gzip wrapper
    gzip.resize(deflateBound(&z, raw.size()) + 32);
    z.next_in = reinterpret_cast<Bytef*>(raw.data());
    z.avail_in = static_cast<uInt>(raw.size());
    z.next_out = reinterpret_cast<Bytef*>(gzip.data());
    z.avail_out = static_cast<uInt>(gzip.size());
    const int rc = deflate(&z, Z_FINISH);
    gzip.resize(rc == Z_STREAM_END ? z.total_out : 0);
    deflateEnd(&z);
  }
  // The response: 304 for a matching If-None-Match, else the bytes (gzip where the client takes it). The content
  void Send(const http::Request& req, http::Response& res, const char* type) const {
    res.set_header("Cache-Control", "public, max-age=86400");
    res.set_header("ETag", etag);
    res.set_header("Vary", "Accept-Encoding");
    if (req.get_header_value("If-None-Match") == etag) {
      res.status = 304;
      return;
    }
    const bool gz = !gzip.empty() && req.get_header_value("Accept-Encoding").find("gzip") != std::string::npos;
    if (gz) res.set_header("Content-Encoding", "gzip");
    res.set_content(gz ? gzip : raw, type);
  }
};

}  // namespace

// The transport's bounds from the service's options (service/http.h).
http::Limits TransportLimits(const ServiceOptions& o) {
  http::Limits l;
  l.body_bytes = static_cast<uint64_t>(o.max_upload_mb) << 20;
  l.header_timeout_s = o.header_timeout_s;
  l.body_timeout_s = o.body_timeout_s;
  l.max_connections = o.max_connections;
  l.handler_threads = o.workers + o.max_queue + 2;  // the admission (workers + queue) answers 503 beyond
  return l;
}

struct Server::Impl {
  ServiceOptions o;
  AnchorStore store;
  Admission admission;
  Metrics metrics;
  JobThreads workers;      // the threads that do the work: `workers` of them, for the life of the server
  http::Server transport;  // last: destroyed (its threads joined) before the workers
  int port = 0;
  StaticAsset three_js, orbit_js, view3d_js;

  explicit Impl(const ServiceOptions& opt)
      : o(opt),
        store(opt.pipeline, opt.max_anchors, opt.store_dir, int64_t{opt.max_upload_mp} * 1000000),
        admission(opt.workers, opt.max_queue),
        workers(opt.workers),
        transport(TransportLimits(opt)) {
    three_js = StaticAsset(ReadStatic(o.static_dir + "/build/three.min.js"));
    orbit_js = StaticAsset(ReadStatic(o.static_dir + "/examples/js/controls/OrbitControls.js"));
    view3d_js = StaticAsset(eval::View3dScript());
    if (three_js.raw.empty())
      FREELOC_LOG(WARNING) << o.static_dir
                           << "/build/three.min.js: not found (install libjs-three); the page's "
                              "3D view is off";
    Routes();
  }

  bool Authorized(const http::Request& req, http::Response& res) {
    // The header, or (for the page's <img> links, which send no headers) a `token` query parameter.
    if (o.token.empty() || SameSecret(req.get_header_value("Authorization"), "Bearer " + o.token) ||
        (req.has_param("token") && SameSecret(req.get_param_value("token"), o.token)))
      return true;
    SendError(res, 401,
              req.has_header("Authorization") ? "Authorization: wrong token"
                                              : "Authorization: this service needs 'Authorization: Bearer <token>'");
    return false;
  }

  // Runs `work` as one admitted unit: 503 when the queue is full (or the wait too long), 400 for bad input
  // (freeloc::Error), 500 for anything else.
  template <typename Fn>
  void Admitted(http::Response& res, const Fn& work) {
    const auto t0 = std::chrono::steady_clock::now();
    if (!admission.Enter(o.queue_timeout_s)) {
      res.set_header("Retry-After", "1");
      SendError(res, 503,
                "busy: " + std::to_string(o.workers) + " workers and " + std::to_string(o.max_queue) +
                    " queued requests; retry later");
      return;
    }
    const double queue_ms = MsSince(t0);
    workers.Run([&] {
      try {
        work(queue_ms);
      } catch (const AnchorStore::StoreFull& e) {
        SendError(res, 507, e.what());
      } catch (const Error& e) {
        SendError(res, 400, e.what());
      } catch (const std::exception& e) {
        FREELOC_LOG(ERROR) << "request failed: " << e.what();
        SendError(res, 500, std::string("internal error: ") + e.what());
      }
    });
    admission.Leave();
  }

  // What went wrong, for the answers the transport gives itself (service/http.h). A body refused for its size that is
  // not multipart at all is the client's format (415), whatever its size.
  std::string HttpErrorText(const http::Request& req, int* status) const {
    if (*status == 413 && !req.is_multipart_form_data()) {
      *status = 415;
      return kMultipartExpected + ContentTypeText(req);
    }
    if (*status == 413) {
      const std::string length = req.get_header_value("Content-Length");
      return "upload too large: " + (length.empty() ? std::string("the body") : SafeText(length, 20) + " bytes") +
             " is over this server's " + "limit of " + std::to_string(o.max_upload_mb) +
             " MB (its max_upload_mb option): send a smaller photo, or restart the server with a larger limit";
    }
    if (*status == 404)
      return "no such route: " + SafeText(req.method, 10) + " " + SafeText(req.path, 80) +
             "; the routes: GET /, /healthz, /metrics, /v1/anchors, /v1/anchors/{id}[/image|/depth|/points]; POST "
             "/v1/anchors, /v1/anchors/{id}/relocalize; DELETE /v1/anchors/{id} (docs/service.md)";
    if (*status == 431) return "request: headers over 16 KiB";
    if (*status == 503) return "busy: too many requests at once; retry later";
    if (*status == 400) return "bad request (malformed HTTP)";
    return "HTTP error " + std::to_string(*status);
  }

  void Routes() {
    transport.SetErrorText([this](const http::Request& req, int* status) { return HttpErrorText(req, status); });
    transport.SetLogger([this](int status) { metrics.Count(status); });

    transport.Route("GET", "/", [this](const http::Request&, http::Response& res) {
      res.set_content(PageHtml(), "text/html; charset=utf-8");
    });
    constexpr const char* kJs = "application/javascript; charset=utf-8";
    transport.Route("GET", "/static/three.min.js", [this, kJs](const http::Request& req, http::Response& res) {
      if (three_js.raw.empty()) return SendError(res, 404, "three.js is not installed (Debian package libjs-three)");
      three_js.Send(req, res, kJs);
    });
    transport.Route("GET", "/static/OrbitControls.js", [this, kJs](const http::Request& req, http::Response& res) {
      if (orbit_js.raw.empty()) return SendError(res, 404, "OrbitControls.js is not installed (libjs-three)");
      orbit_js.Send(req, res, kJs);
    });
    transport.Route("GET", "/static/view3d.js",
                    [this, kJs](const http::Request& req, http::Response& res) { view3d_js.Send(req, res, kJs); });
    transport.Route("GET", "/healthz", [this](const http::Request&, http::Response& res) {
      SendJson(res, 200, {{"status", "ok"}, {"anchors", store.size()}});
    });
    transport.Route("GET", "/metrics", [this](const http::Request& req, http::Response& res) {
      if (!Authorized(req, res)) return;
      Json j = metrics.ToJson();
      j["queue"] = admission.waiting();
      j["in_flight"] = admission.running();
      j["anchors"] = store.size();
      j["rss_mb"] = ProcMiB("VmRSS:");
      j["peak_rss_mb"] = ProcMiB("VmHWM:");
      SendJson(res, 200, j);
    });

    transport.Route(
        "POST", "/v1/anchors",
        [this](const http::Request& req, http::Response& res) {
          if (NotMultipart(req, res)) return;
          const auto t0 = std::chrono::steady_clock::now();
          if (Authorized(req, res)) {
            try {
              PhotoUpload u = UploadOf(req);
              Admitted(res, [&](double queue_ms) {
                const std::shared_ptr<Anchor> a = store.Add(std::move(u));
                Json j = AnchorJson(*a);
                j["queue_ms"] = queue_ms;
                SendJson(res, 201, j);
              });
            } catch (const Error& e) {
              SendError(res, 400, e.what());
            }
          }
          metrics.Latency(MsSince(t0));
        },
        /*heavy=*/true);
    transport.Route("GET", "/v1/anchors", [this](const http::Request& req, http::Response& res) {
      if (!Authorized(req, res)) return;
      Json list = Json::array();
      for (const auto& a : store.List()) list.push_back(AnchorJson(*a));
      SendJson(res, 200, {{"anchors", list}});
    });
    const std::string id = "/v1/anchors/([^/]{1,200})";  // any text: looked up, never a path
    transport.Route("GET", id, [this](const http::Request& req, http::Response& res) {
      if (!Authorized(req, res)) return;
      const auto a = store.Get(req.matches[1]);
      if (!a) return SendUnknownAnchor(res, req.matches[1]);
      SendJson(res, 200, AnchorJson(*a));
    });
    transport.Route("DELETE", id, [this](const http::Request& req, http::Response& res) {
      if (!Authorized(req, res)) return;
      if (!store.Remove(req.matches[1])) return SendUnknownAnchor(res, req.matches[1]);
      SendJson(res, 200, {{"deleted", std::string(req.matches[1])}});
    });
    transport.Route("GET", id + "/image", [this](const http::Request& req, http::Response& res) {
      if (!Authorized(req, res)) return;
      const auto a = store.Get(req.matches[1]);
      if (!a) return SendUnknownAnchor(res, req.matches[1]);
      if (req.has_param("raw") && req.get_param_value("raw") == "1")  // the uploaded file itself (EXIF and all)
        return res.set_content(std::string(a->upload.image.begin(), a->upload.image.end()), "application/octet-stream");
      const std::vector<uint8_t> jpg =
          io::EncodeJpeg(a->image, 90, "anchor image");  // upright, as the pipeline sees it
      res.set_content(std::string(jpg.begin(), jpg.end()), "image/jpeg");
    });
    transport.Route("GET", id + "/depth", [this](const http::Request& req, http::Response& res) {
      if (!Authorized(req, res)) return;
      const auto a = store.Get(req.matches[1]);
      if (!a) return SendUnknownAnchor(res, req.matches[1]);
      if (req.has_param("raw") && req.get_param_value("raw") == "1") {  // the uploaded 16-bit PNG itself
        if (!a->has_depth) return SendError(res, 404, "anchor " + a->id + ": no depth was uploaded");
        return res.set_content(std::string(a->upload.depth.begin(), a->upload.depth.end()), "image/png");
      }
      std::lock_guard<std::mutex> lock(a->mu);
      const DepthMap& d = a->reloc->reference_depth();
      if (d.empty()) return SendError(res, 404, "anchor " + a->id + ": no depth (none uploaded, none estimated)");
      const std::vector<uint8_t> jpg = DepthPicture(d);
      res.set_content(std::string(jpg.begin(), jpg.end()), "image/jpeg");
    });
    transport.Route("GET", id + "/points", [this](const http::Request& req, http::Response& res) {
      if (!Authorized(req, res)) return;
      const auto a = store.Get(req.matches[1]);
      if (!a) return SendUnknownAnchor(res, req.matches[1]);
      std::lock_guard<std::mutex> lock(a->mu);
      Camera k = a->intrinsics.camera;
      k.width = a->image.width;
      k.height = a->image.height;
      SendJson(res, 200,
               Json::parse(eval::View3dJson(a->image, a->reloc->reference_depth(), k,
                                            {{Rigid3d(), k, "#33dd66", "reference"}})));
    });
    transport.Route(
        "POST", id + "/relocalize",
        [this](const http::Request& req, http::Response& res) {
          if (NotMultipart(req, res)) return;
          const auto t0 = std::chrono::steady_clock::now();
          if (Authorized(req, res)) Relocalize(req, res, t0);
          metrics.Latency(MsSince(t0));
        },
        /*heavy=*/true);
  }

  void Relocalize(const http::Request& req, http::Response& res, std::chrono::steady_clock::time_point t0) {
    const auto a = store.Get(req.matches[1]);
    if (!a) return SendUnknownAnchor(res, req.matches[1]);
    PhotoUpload u;
    try {
      u = UploadOf(req);
    } catch (const Error& e) {
      return SendError(res, 400, e.what());
    }
    const bool view = req.has_param("view") && req.get_param_value("view") == "1";
    Admitted(res, [&](double queue_ms) {
      const auto td = std::chrono::steady_clock::now();
      DecodedPhoto p = DecodePhoto(u, a->reloc->options(), "query", store.max_pixels());
      const double decode_ms = MsSince(td);
      std::lock_guard<std::mutex> lock(a->mu);
      matching::Correspondences c;
      const pipeline::CacheStats before = a->reloc->stats();
      const pipeline::QueryResult q = a->reloc->Relocalize(p.image, p.camera, std::move(p.inputs), &c);
      const pipeline::CacheStats& after = a->reloc->stats();
      ++a->queries;
      Json j = Json::parse(pipeline::QueryRecordJson("", q, &a->reloc->options()));
      j["anchor"] = a->id;
      // The reference side ran when the anchor was added (its reference_ms); measured here: no reference encoder
      // pass and no reference depth estimate ran for this query (the counters did not move).
      j["service"] = {{"queue_ms", queue_ms},
                      {"decode_ms", decode_ms},
                      {"total_ms", MsSince(t0)},
                      {"reference_encodings", after.reference_encodings},
                      {"reference_reuses", a->queries},
                      {"reference_reused", after.reference_encodings == before.reference_encodings &&
                                               after.reference_ms == before.reference_ms}};
      if (view) {
        Json m = Json::array();
        constexpr size_t kLines = 150;  // as the report draws (eval::ReportOptions::max_lines)
        const size_t n = c.size(), step = std::max<size_t>(1, (n + kLines - 1) / kLines);
        // In the pixels of the images the page draws (the working-resolution copies; the matches are in the photos').
        const double sr = static_cast<double>(a->image.width) / a->image.PhotoWidth(),
                     sq = static_cast<double>(p.image.width) / p.image.PhotoWidth();
        for (size_t i = 0; i < n; i += step)
          m.push_back({c.ref[i].x() * sr, c.ref[i].y() * sr, c.query[i].x() * sq, c.query[i].y() * sq,
                       i < q.inlier_mask.size() && q.inlier_mask[i] ? 1 : 0});
        j["view"] = {{"matches", m}};
        const DepthMap& dq = a->reloc->last_query_depth();
        if (!dq.empty()) j["view"]["query_depth"] = "data:image/jpeg;base64," + Base64(DepthPicture(dq));
        Camera kr = a->intrinsics.camera, kq = q.query_intrinsics.camera;
        kr.width = a->image.width;
        kr.height = a->image.height;
        kq.width = p.image.width;
        kq.height = p.image.height;
        std::vector<eval::View3dCamera> cams = {{Rigid3d(), kr, "#33dd66", "reference"}};
        if (q.ok() || q.weak()) cams.push_back({q.query_from_ref, kq, "#ff9922", "predicted"});
        j["view"]["view3d"] = Json::parse(eval::View3dJson(a->image, a->reloc->reference_depth(), kr, cams));
        const std::vector<uint8_t> qj = io::EncodeJpeg(p.image, 85, "query image");
        j["view"]["query_image"] = "data:image/jpeg;base64," + Base64(qj);
      }
      SendJson(res, 200, j);
    });
  }
};

Server::Server(const ServiceOptions& options) {
  options.Validate();
  impl_ = std::make_unique<Impl>(options);
}

Server::~Server() = default;

int Server::Bind() {
  impl_->port = impl_->transport.Bind(impl_->o.host, impl_->o.port);
  return impl_->port;
}

void Server::Serve() { impl_->transport.Serve(); }
void Server::Stop() { impl_->transport.Stop(); }
int Server::port() const { return impl_->port; }

}  // namespace freeloc::service
