// `freeloc serve` over HTTP on a free localhost port: every route, every error code, the answer equal to
// `freeloc relocalize --json`, concurrent requests, backpressure, persistence and a clean stop.
#include "freeloc/service/server.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "freeloc/io/file_util.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/pipeline/options.h"
#include "testing/testing.h"

namespace freeloc::service {
namespace {

using Json = nlohmann::json;

std::string Bytes(const std::string& path) {
  const std::vector<uint8_t> b = io::ReadFileBytes(path);
  return std::string(b.begin(), b.end());
}

const char* kK = "520.908620,521.007327,325.141442,249.701764";  // s00003's intrinsics

struct Tum {
  std::string ref, query, ref_depth, query_depth;
  Tum() {
    const std::string s = testing::DemoPath("val/s00003/");
    ref = Bytes(s + "seq0/frame_00000.png");
    query = Bytes(s + "seq1/frame_00000.png");
    ref_depth = Bytes(s + "seq0/frame_00000.sensor.png");
    query_depth = Bytes(s + "seq1/frame_00000.sensor.png");
  }
};

httplib::MultipartFormDataItems Photo(const std::string& image, const std::string& depth = "",
                                      const std::string& k = kK) {
  httplib::MultipartFormDataItems items = {{"image", image, "photo.png", "image/png"}};
  if (!depth.empty()) items.push_back({"depth", depth, "depth.png", "image/png"});
  if (!k.empty()) items.push_back({"intrinsics", k, "", ""});
  return items;
}

std::string AddAnchor(httplib::Client& c, const Tum& t) {
  auto r = c.Post("/v1/anchors", Photo(t.ref, t.ref_depth));
  EXPECT_TRUE(r);
  if (!r) return "";
  EXPECT_EQ(r->status, 201) << r->body;
  return Json::parse(r->body).value("id", std::string());
}

// A client still sending when the server refuses its body gets EPIPE, not a signal that ends the test.
const bool kNoSigpipe = [] {
  std::signal(SIGPIPE, SIG_IGN);
  return true;
}();

// A server on a free port, serving from a thread until the fixture ends.
class Running {
 public:
  explicit Running(ServiceOptions o) {
    o.port = 0;
    server_ = std::make_unique<Server>(o);
    port_ = server_->Bind();
    thread_ = std::thread([this] { server_->Serve(); });
  }
  ~Running() {
    server_->Stop();
    thread_.join();
  }
  httplib::Client Client(const std::string& token = "") const {
    httplib::Client c("127.0.0.1", port_);
    c.set_read_timeout(120, 0);
    if (!token.empty()) c.set_bearer_token_auth(token.c_str());
    return c;
  }
  int port() const { return port_; }
  // Posts the scene's reference photo as an anchor; its id.
  std::string AddAnchor(const Tum& t) const {
    httplib::Client c = Client();
    return service::AddAnchor(c, t);
  }

 private:
  std::unique_ptr<Server> server_;
  int port_ = 0;
  std::thread thread_;
};

ServiceOptions Sift() {
  ServiceOptions o;
  o.pipeline = pipeline::ResolvePreset("sift-essential");
  return o;
}

TEST(Service, RoutesAndTheAnswerOfRelocalize) {
  const Tum t;
  const Running s(Sift());
  httplib::Client c = s.Client();
  auto r = c.Get("/healthz");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  const std::string id = AddAnchor(c, t);
  ASSERT_EQ(id.size(), 16u);
  r = c.Get("/v1/anchors");
  ASSERT_TRUE(r);
  EXPECT_EQ(Json::parse(r->body)["anchors"].size(), 1u);
  r = c.Get(("/v1/anchors/" + id).c_str());
  ASSERT_EQ(r->status, 200);
  EXPECT_EQ(Json::parse(r->body)["intrinsics"]["source"], "given");
  EXPECT_EQ(c.Get(("/v1/anchors/" + id + "/image").c_str())->get_header_value("Content-Type"), "image/jpeg");
  EXPECT_EQ(c.Get(("/v1/anchors/" + id + "/depth").c_str())->status, 200);
  const Json pts = Json::parse(c.Get(("/v1/anchors/" + id + "/points").c_str())->body);
  EXPECT_GT(pts["points"].size(), 3000u);
  EXPECT_EQ(pts["points"].size(), pts["colors"].size());

  // The answer over HTTP is `freeloc relocalize --json` on the same inputs: same pose, status, confidence.
  r = c.Post(("/v1/anchors/" + id + "/relocalize").c_str(), Photo(t.query, t.query_depth));
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const Json http = Json::parse(r->body);
  const std::string s3 = testing::DemoPath("val/s00003/");
  const std::string cmd = std::string(FREELOC_BINARY) + " relocalize --ref " + s3 + "seq0/frame_00000.png --query " +
                          s3 + "seq1/frame_00000.png --ref-intrinsics " + kK + " --query-intrinsics " + kK +
                          " --ref-depth " + s3 + "seq0/frame_00000.sensor.png --query-depth " + s3 +
                          "seq1/frame_00000.sensor.png --json";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof(buf), p)) > 0) out.append(buf, n);
  pclose(p);
  const Json cli = Json::parse(out);
  EXPECT_EQ(http["status"], "ok");
  EXPECT_EQ(http["status"], cli["status"]);
  EXPECT_EQ(http["qvec"], cli["qvec"]);
  EXPECT_EQ(http["tvec"], cli["tvec"]);
  EXPECT_EQ(http["confidence"], cli["confidence"]);
  EXPECT_EQ(http["inliers"], cli["inliers"]);
  EXPECT_EQ(http["options"], cli["options"]);
  // A warm anchor: the reference side is not in the query's cost.
  EXPECT_TRUE(http["service"]["reference_reused"].get<bool>());
  EXPECT_FALSE(http.contains("view"));
  r = c.Post(("/v1/anchors/" + id + "/relocalize?view=1").c_str(), Photo(t.query, t.query_depth));
  const Json view = Json::parse(r->body)["view"];
  EXPECT_GT(view["matches"].size(), 100u);
  EXPECT_EQ(view["query_image"].get<std::string>().rfind("data:image/jpeg;base64,", 0), 0u);

  // The page and its scripts, all from this server.
  r = c.Get("/");
  ASSERT_EQ(r->status, 200);
  EXPECT_NE(r->body.find("/static/three.min.js"), std::string::npos);
  EXPECT_EQ(r->body.find("http://"), std::string::npos);  // nothing loaded from elsewhere
  EXPECT_EQ(r->body.find("https://"), std::string::npos);
  if (std::filesystem::exists("/usr/share/javascript/three/build/three.min.js")) {
    EXPECT_EQ(c.Get("/static/three.min.js")->status, 200);
    // Compressed once at start, cached by the browser: gzip where asked (the client unpacks it to the file's
    // bytes), an ETag, Cache-Control, and 304 for a matching If-None-Match.
    const auto js = c.Get("/static/three.min.js", {{"Accept-Encoding", "gzip"}});
    ASSERT_TRUE(js);
    EXPECT_EQ(js->get_header_value("Content-Encoding"), "gzip");
    EXPECT_EQ(js->body, Bytes("/usr/share/javascript/three/build/three.min.js"));
    EXPECT_EQ(js->get_header_value("Cache-Control"), "public, max-age=86400");
    const std::string etag = js->get_header_value("ETag");
    ASSERT_FALSE(etag.empty());
    const auto again = c.Get("/static/three.min.js", {{"If-None-Match", etag}});
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 304);
  }

  r = c.Delete(("/v1/anchors/" + id).c_str());
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(c.Delete(("/v1/anchors/" + id).c_str())->status, 404);
  const Json metrics = Json::parse(c.Get("/metrics")->body);
  EXPECT_GE(metrics["requests"].get<int>(), 3);
  EXPECT_GT(metrics["rss_mb"].get<double>(), 0);
}

// With a network preset (DUSt3R, tiny fixture weights) the anchor's reference work — model loading, the reference's
// encoder pass — runs once, when it is added: queries add no reference encoding.
TEST(Service, WarmAnchorsRunOnlyTheQueryWork) {
  const Tum t;
  ServiceOptions o;
  o.pipeline = pipeline::ResolvePreset("dust3r");
  o.pipeline.models.dust3r_model = testing::TinyModelPath("dust3r_tiny.pth");
  o.pipeline.pointmap.dust3r_size = 224;
  o.pipeline.pointmap.check_intrinsics = 0;
  const Running s(o);
  httplib::Client c = s.Client();
  const std::string id = AddAnchor(c, t);
  ASSERT_FALSE(id.empty());
  int encodings = -1, reuses = -1;
  for (int i = 0; i < 3; ++i) {
    const auto r = c.Post(("/v1/anchors/" + id + "/relocalize").c_str(), Photo(t.query, t.query_depth));
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
    const Json j = Json::parse(r->body);
    EXPECT_TRUE(j["service"]["reference_reused"].get<bool>()) << r->body;
    if (encodings < 0) encodings = j["service"]["reference_encodings"];
    EXPECT_EQ(j["service"]["reference_encodings"], encodings);
    if (reuses < 0) reuses = j["service"]["reference_reuses"];
    EXPECT_EQ(j["service"]["reference_reuses"].get<int>(), reuses + i);  // one reuse of the encoding per query
  }
  EXPECT_EQ(encodings, 1);
}

// Bad input gets a 4xx with a message naming what is wrong, and the server keeps serving.
TEST(Service, BadInputIsAClearClientError) {
  const Tum t;
  ServiceOptions o = Sift();
  o.max_upload_mb = 1;
  const Running s(o);
  httplib::Client c = s.Client();
  const std::string id = AddAnchor(c, t);
  const std::string reloc = "/v1/anchors/" + id + "/relocalize";
  const auto expect = [&](const httplib::Result& r, int status, const std::string& part) {
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, status) << r->body;
    const Json j = Json::parse(r->body, nullptr, false);
    ASSERT_TRUE(j.is_object()) << r->body;
    EXPECT_NE(j.value("error", std::string()).find(part), std::string::npos) << r->body;
  };
  expect(c.Post(reloc.c_str(), "not a form", "text/plain"), 415, "expected multipart/form-data");
  expect(c.Post(reloc.c_str(), httplib::MultipartFormDataItems{{"depth", t.query_depth, "d.png", "image/png"}}), 400,
         "image: missing");
  expect(c.Post(reloc.c_str(), Photo(t.query.substr(0, t.query.size() / 2))), 400, "truncated");
  expect(c.Post(reloc.c_str(), Photo("GIF89a garbage")), 400, "not a supported image");
  expect(c.Post(reloc.c_str(), Photo(t.query, "", "1,2,three")), 400, "intrinsics");
  expect(c.Post(reloc.c_str(), Photo(t.query, "", "1e308,1e308,320,240")), 400, "intrinsics");
  expect(c.Post(reloc.c_str(), Photo(t.query, t.ref)), 400, "depth");  // an 8-bit RGB PNG as the depth map
  expect(c.Post("/v1/anchors/0123456789abcdef/relocalize", Photo(t.query)), 404, "unknown");
  expect(c.Post("/v1/anchors/not-an-anchor/relocalize", Photo(t.query)), 404,
         "anchor 'not-an-anchor': unknown (deleted, never added");
  expect(c.Get("/v1/anchors/..%2f..%2fetc/image"), 404, "no such route");  // ids are looked up, never paths
  expect(c.Get("/nowhere"), 404, "no such route: GET /nowhere; the routes:");
  // A photo posted raw (curl --data-binary sends it form-urlencoded): the format is wrong, whatever its size.
  expect(c.Post(reloc.c_str(), t.query, "application/x-www-form-urlencoded"), 415, "expected multipart/form-data");
  expect(c.Post(reloc.c_str(), t.query, "image/png"), 415, "expected multipart/form-data");
  // Bytes that are not UTF-8 in a field, and in the Content-Type: a clear 400, never an aborted server.
  expect(c.Post(reloc.c_str(), Photo(t.query, "", "5\xff0,1,2,3")), 400, "intrinsics");
  expect(c.Post(reloc.c_str(), "x", "text/\xe9t\xe9"), 415, "expected multipart/form-data");
  // A PNG that declares 100000 x 100000 pixels.
  std::string huge = t.query.substr(0, 33);
  for (int k : {16, 20}) {
    huge[k] = 0;
    huge[k + 1] = 1;
    huge[k + 2] = static_cast<char>(0x86);
    huge[k + 3] = static_cast<char>(0xA0);
  }
  expect(c.Post(reloc.c_str(), Photo(huge + t.query.substr(33))), 400, "pixels");
  // 13000 x 13000 (169 MP, under the readers' own limit): refused by the server's max_upload_mp before decoding.
  std::string big = t.query.substr(0, 33);
  for (int k : {16, 20}) {
    big[k] = 0;
    big[k + 1] = 0;
    big[k + 2] = static_cast<char>(0x32);
    big[k + 3] = static_cast<char>(0xC8);
  }
  expect(c.Post(reloc.c_str(), Photo(big + t.query.substr(33))), 400,
         "declares 13000 x 13000 pixels, more than this server takes (50 MP, its max_upload_mp option)");
  // Bodies over --max-upload-mb, and a declared length far over it: 413 before reading them.
  expect(c.Post(reloc.c_str(), Photo(std::string(2 << 20, 'x'))), 413,
         "is over this server's limit of 1 MB (its max_upload_mb option)");
  {
    httplib::Client raw("127.0.0.1", s.port());
    httplib::Headers h = {{"Content-Length", "1000000000000"}};
    const auto r = raw.Post(reloc.c_str(), h, "x", 1, "multipart/form-data; boundary=b");
    if (r) {
      EXPECT_EQ(r->status, 413) << r->body;  // (or the connection is closed)
    }
  }
  // A malformed multipart body.
  expect(c.Post(reloc.c_str(), "--b\r\nContent-Disposition: form-data; name=\"image\"\r\n\r\nabc",
                "multipart/form-data; boundary=b"),
         400, "");
  // Still serving, the anchor intact.
  const auto r = c.Post(reloc.c_str(), Photo(t.query, t.query_depth));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
}

// The plausible-input rule (inputs/input_checks.h) through the service: depth in another unit and a transposed
// depth map refused naming the fix, a `depth_unit` field taken with its map, normalised intrinsics refused.
TEST(Service, PlausibleInputsAreRefusedWithTheFixOrTakenAsSaid) {
  const Tum t;
  const Running s(Sift());
  httplib::Client c = s.Client();
  const std::string id = AddAnchor(c, t);
  const std::string reloc = "/v1/anchors/" + id + "/relocalize";
  const auto good = c.Post(reloc.c_str(), Photo(t.query, t.query_depth));
  ASSERT_TRUE(good);
  ASSERT_EQ(good->status, 200) << good->body;
  const Json want = Json::parse(good->body);
  testing::TempDir tmp;
  const DepthMap q = io::ReadDepthPng(testing::DemoPath("val/s00003/seq1/frame_00000.sensor.png"));
  const auto png = [&](const DepthMap& d) {
    io::WriteDepthPng(tmp.File("d.png"), d);
    return Bytes(tmp.File("d.png"));
  };
  DepthMap cm = q, tr(q.height, q.width);
  for (float& v : cm.data) v = std::round(v * 100) / 1000;  // centimetres as integers
  for (int y = 0; y < q.height; ++y)
    for (int x = 0; x < q.width; ++x) tr.at(y, x) = q.at(x, y);
  auto r = c.Post(reloc.c_str(), Photo(t.query, png(cm)));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400) << r->body;
  EXPECT_NE(r->body.find("set depth_unit=cm"), std::string::npos) << r->body;
  auto items = Photo(t.query, png(cm));
  items.push_back({"depth_unit", "cm", "", ""});
  r = c.Post(reloc.c_str(), items);
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const Json j = Json::parse(r->body);
  EXPECT_EQ(j["status"], "ok");
  const Eigen::Vector3d tg(j["tvec"][0], j["tvec"][1], j["tvec"][2]),
      tw(want["tvec"][0], want["tvec"][1], want["tvec"][2]);
  EXPECT_LT((tg - tw).norm(), 0.05 * tw.norm()) << r->body;
  items.back() = {"depth_unit", "furlong", "", ""};
  r = c.Post(reloc.c_str(), items);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400) << r->body;
  EXPECT_NE(r->body.find("not one of mm, cm, m"), std::string::npos) << r->body;
  r = c.Post(reloc.c_str(), Photo(t.query, png(tr)));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400) << r->body;
  EXPECT_NE(r->body.find("transposed"), std::string::npos) << r->body;
  r = c.Post(reloc.c_str(), Photo(t.query, t.query_depth, "0.8139,0.8141,0.508,0.52"));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400) << r->body;
  EXPECT_NE(r->body.find("look normalised"), std::string::npos) << r->body;
}

TEST(Service, TokenIsRequiredWhenSet) {
  const Tum t;
  ServiceOptions o = Sift();
  o.token = "s3cret";
  const Running s(o);
  httplib::Client none = s.Client(), wrong = s.Client("nope"), right = s.Client("s3cret");
  EXPECT_EQ(none.Get("/v1/anchors")->status, 401);
  EXPECT_EQ(wrong.Get("/v1/anchors")->status, 401);
  EXPECT_EQ(wrong.Post("/v1/anchors", Photo(t.ref))->status, 401);
  EXPECT_EQ(wrong.Get("/metrics")->status, 401);
  EXPECT_EQ(right.Get("/v1/anchors")->status, 200);
  EXPECT_EQ(none.Get("/healthz")->status, 200);
  // A prefix, a longer token, the token with a byte changed: refused alike (compared in constant time).
  for (const char* guess : {"s3cre", "s3cret!", "s3creT", ""})
    EXPECT_EQ(s.Client().Get((std::string("/v1/anchors?token=") + guess).c_str())->status, 401) << guess;
  EXPECT_EQ(s.Client().Get("/v1/anchors?token=s3cret")->status, 200);
}

// 16 concurrent requests against one anchor all succeed with the same answer; with one worker and a queue of one,
// a burst is answered 503 beyond what fits, never queued without bound.
struct Reply {
  int status = 0;  // 0: no answer
  std::string tvec, retry_after;
};

// `n` concurrent relocalize requests of the scene's query against anchor `id`, each on its own connection.
std::vector<Reply> Burst(const Running& s, const std::string& id, const Tum& t, int n) {
  std::vector<Reply> replies(n);
  std::vector<std::thread> threads;
  for (int i = 0; i < n; ++i)
    threads.emplace_back([&, i] {
      httplib::Client c = s.Client();
      const auto r = c.Post(("/v1/anchors/" + id + "/relocalize").c_str(), Photo(t.query, t.query_depth));
      if (!r) return;
      replies[i].status = r->status;
      replies[i].retry_after = r->get_header_value("Retry-After");
      if (r->status == 200) replies[i].tvec = Json::parse(r->body)["tvec"].dump();
    });
  for (auto& th : threads) th.join();
  return replies;
}

TEST(Service, ConcurrencyAndBackpressure) {
  const Tum t;
  ServiceOptions o = Sift();
  o.workers = 2;
  {
    const Running s(o);
    const std::vector<Reply> replies = Burst(s, s.AddAnchor(t), t, 16);
    for (const Reply& r : replies) {
      EXPECT_EQ(r.status, 200);
      EXPECT_EQ(r.tvec, replies[0].tvec);
    }
  }
  o.workers = 1;
  o.max_queue = 1;
  const Running s(o);
  int ok = 0, busy = 0, other = 0;
  for (const Reply& r : Burst(s, s.AddAnchor(t), t, 8)) {
    if (r.status == 200) {
      ++ok;
    } else if (r.status == 503 && r.retry_after == "1") {
      ++busy;
    } else {
      ++other;
    }
  }
  EXPECT_GE(ok, 2);
  EXPECT_GE(busy, 1);
  EXPECT_EQ(other, 0);
  const Json m = Json::parse(s.Client().Get("/metrics")->body);
  EXPECT_EQ(m["queue"], 0);
  EXPECT_EQ(m["in_flight"], 0);
  EXPECT_EQ(m["errors"].value("503", 0), busy);
}

// Anchors persisted with --store come back after a restart and answer the same; --max-anchors is enforced.
TEST(Service, StoreSurvivesARestartAndMaxAnchorsHolds) {
  const Tum t;
  const testing::TempDir tmp;
  ServiceOptions o = Sift();
  o.store_dir = tmp.File("anchors");
  o.max_anchors = 1;
  std::string id, before;
  {
    const Running s(o);
    httplib::Client c = s.Client();
    id = AddAnchor(c, t);
    before = c.Post(("/v1/anchors/" + id + "/relocalize").c_str(), Photo(t.query, t.query_depth))->body;
    const auto full = c.Post("/v1/anchors", Photo(t.ref, t.ref_depth));
    EXPECT_EQ(full->status, 507) << full->body;
  }
  const Running s(o);
  httplib::Client c = s.Client();
  const auto r = c.Post(("/v1/anchors/" + id + "/relocalize").c_str(), Photo(t.query, t.query_depth));
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(Json::parse(r->body)["tvec"], Json::parse(before)["tvec"]);
  EXPECT_EQ(c.Delete(("/v1/anchors/" + id).c_str())->status, 200);
  EXPECT_FALSE(std::filesystem::exists(tmp.File("anchors/" + id)));
}

// A --store whose anchors were damaged (a truncated meta.json, a wrong-typed field, a missing image): each is set
// aside into quarantine/ with a warning at start, the others load and answer as before.
TEST(Service, DamagedStoredAnchorsAreQuarantinedAndTheRestLoad) {
  const Tum t;
  const testing::TempDir tmp;
  ServiceOptions o = Sift();
  o.store_dir = tmp.File("anchors");
  o.max_anchors = 4;
  std::vector<std::string> ids;
  std::string before;
  {
    const Running s(o);
    httplib::Client c = s.Client();
    for (int i = 0; i < 4; ++i) ids.push_back(AddAnchor(c, t));
    before = c.Post(("/v1/anchors/" + ids[0] + "/relocalize").c_str(), Photo(t.query, t.query_depth))->body;
  }
  const auto write = [&](const std::string& path, const std::string& text) {
    std::ofstream f(tmp.File("anchors/" + path), std::ios::binary | std::ios::trunc);
    f << text;
  };
  write(ids[1] + "/meta.json", "{\"intrinsics\": \"5");
  write(ids[2] + "/meta.json", "{\"intrinsics\": \"\", \"depth\": \"yes\"}");
  std::filesystem::remove(tmp.File("anchors/" + ids[3] + "/image"));
  const Running s(o);
  httplib::Client c = s.Client();
  EXPECT_EQ(Json::parse(c.Get("/healthz")->body)["anchors"], 1);
  const auto r = c.Post(("/v1/anchors/" + ids[0] + "/relocalize").c_str(), Photo(t.query, t.query_depth));
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(Json::parse(r->body)["tvec"], Json::parse(before)["tvec"]);
  for (int i = 1; i < 4; ++i) {
    EXPECT_TRUE(std::filesystem::exists(tmp.File("anchors/quarantine/" + ids[i]))) << i;
    EXPECT_FALSE(std::filesystem::exists(tmp.File("anchors/" + ids[i]))) << i;
    EXPECT_EQ(c.Get(("/v1/anchors/" + ids[i]).c_str())->status, 404);
  }
}

// A raw TCP client for the hostile cases: what it sends is exactly what a hostile client sends.
class Raw {
 public:
  explicit Raw(int port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ok_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof(a)) == 0;
    timeval tv{10, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
  }
  ~Raw() { ::close(fd_); }
  bool ok() const { return ok_; }
  bool Send(const std::string& s) {
    return ::send(fd_, s.data(), s.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(s.size());
  }
  // Everything the server sends until it closes (or 10 s pass).
  std::string ReadAll() {
    std::string out;
    char buf[4096];
    for (ssize_t n; (n = ::recv(fd_, buf, sizeof(buf), 0)) > 0;) out.append(buf, static_cast<size_t>(n));
    return out;
  }
  // The status of the first answer ("" when the connection closed without one).
  std::string Status() {
    const std::string r = ReadAll();
    return r.rfind("HTTP/1.1 ", 0) == 0 ? r.substr(9, 3) : "";
  }

 private:
  int fd_ = -1;
  bool ok_ = false;
};

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The service as an internet-facing server: lying lengths, hostile chunking, 100-continue, slow clients and too many
// connections are answered at once or bounded in time; /healthz answers throughout and a good request keeps its exact
// answer. (Before, on cpp-httplib 0.11.4: 100 GB declared with 10 bytes sent, or a chunk size of -5, was answered only
// after the 30 s read timeout; a chunked upload beat the size limit; 12 slow clients stopped /healthz.)
TEST(Service, HostileClientsAreBoundedAndTheServerKeepsServing) {
  const Tum t;
  ServiceOptions o = Sift();
  o.max_upload_mb = 2;
  o.header_timeout_s = 1;
  o.max_connections = 40;
  const Running s(o);
  httplib::Client c = s.Client();
  const std::string id = AddAnchor(c, t);
  const std::string reloc = "/v1/anchors/" + id + "/relocalize";
  const std::string good = c.Post(reloc.c_str(), Photo(t.query, t.query_depth))->body;
  const auto healthy = [&] {
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = s.Client().Get("/healthz");
    return r && r->status == 200 && Seconds(t0) < 1.0;
  };
  const std::string post = "POST " + reloc + " HTTP/1.1\r\nHost: x\r\n";
  {  // 100 GB declared, 10 bytes sent: 413 at once, naming the limit
    Raw r(s.port());
    const auto t0 = std::chrono::steady_clock::now();
    r.Send(post + "Content-Type: multipart/form-data; boundary=b\r\nContent-Length: 100000000000\r\n\r\n0123456789");
    const std::string answer = r.ReadAll();
    EXPECT_EQ(answer.substr(9, 3), "413") << answer;
    EXPECT_NE(answer.find("limit of 2 MB"), std::string::npos) << answer;
    EXPECT_LT(Seconds(t0), 3.0);  // (the lingering close waits at most 2 s for the client to stop sending)
  }
  {  // Expect: 100-continue with 100 GB: refused without inviting the upload
    Raw r(s.port());
    r.Send(post +
           "Content-Type: multipart/form-data; boundary=b\r\nContent-Length: 100000000000\r\nExpect: "
           "100-continue\r\n\r\n");
    const std::string answer = r.ReadAll();
    EXPECT_EQ(answer.substr(9, 3), "413") << answer;
    EXPECT_EQ(answer.find("100 Continue"), std::string::npos) << answer;
  }
  {  // a chunk size of -5: 400 at once
    Raw r(s.port());
    const auto t0 = std::chrono::steady_clock::now();
    r.Send(post + "Content-Type: multipart/form-data; boundary=b\r\nTransfer-Encoding: chunked\r\n\r\n-5\r\nabc\r\n");
    EXPECT_EQ(r.Status(), "400");
    EXPECT_LT(Seconds(t0), 3.0);
  }
  {  // a chunked body of 2.4 MB against a 2 MB limit: 413, however it is chunked
    Raw r(s.port());
    r.Send(post + "Content-Type: multipart/form-data; boundary=b\r\nTransfer-Encoding: chunked\r\n\r\n");
    const std::string chunk(100000, 'x');
    char size[32];
    std::snprintf(size, sizeof(size), "%zx\r\n", chunk.size());
    for (int i = 0; i < 24 && r.Send(size + chunk + "\r\n"); ++i) {
    }
    r.Send("0\r\n\r\n");
    EXPECT_EQ(r.Status(), "413");
  }
  {  // headers 20 KiB long: 431
    Raw r(s.port());
    r.Send("GET /healthz HTTP/1.1\r\nX-Junk: " + std::string(20000, 'a') + "\r\n\r\n");
    EXPECT_EQ(r.Status(), "431");
  }
  // 30 clients sending their headers a byte at a time: /healthz answers meanwhile, and each slow client is closed
  // after the header time limit (1 s here; 10 s by default).
  std::vector<std::unique_ptr<Raw>> slow;
  for (int i = 0; i < 30; ++i) {
    slow.push_back(std::make_unique<Raw>(s.port()));
    slow.back()->Send("G");
  }
  EXPECT_TRUE(healthy());
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  for (auto& r : slow) r->Send("E");
  EXPECT_TRUE(healthy());
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(slow.front()->ReadAll(), "");  // closed
  EXPECT_LT(Seconds(t0), 3.0);
  slow.clear();
  std::this_thread::sleep_for(std::chrono::seconds(1));  // the server sees them closed and counts them out
  // More connections than max_connections: the extra ones get 503 at once, and are closed.
  std::vector<std::unique_ptr<Raw>> idle;
  for (int i = 0; i < 40; ++i) idle.push_back(std::make_unique<Raw>(s.port()));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // (accepted, not timed out: header limit 1 s)
  {
    Raw extra(s.port());
    EXPECT_EQ(extra.Status(), "503");
  }
  idle.clear();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  // After all that: healthy (also to a monitor's HEAD: headers only), and a good request gets the same answer.
  EXPECT_TRUE(healthy());
  const auto head = c.Head("/healthz");
  ASSERT_TRUE(head);
  EXPECT_EQ(head->status, 200);
  EXPECT_TRUE(head->body.empty());
  EXPECT_NE(head->get_header_value("Content-Length"), "0");
  const auto after = c.Post(reloc.c_str(), Photo(t.query, t.query_depth));
  ASSERT_TRUE(after);
  EXPECT_EQ(Json::parse(after->body)["tvec"], Json::parse(good)["tvec"]);
  EXPECT_EQ(Json::parse(after->body)["qvec"], Json::parse(good)["qvec"]);
}

// Stop() (SIGTERM) while a client sends its headers at a byte a second: the server stops at once.
TEST(Service, StopIsNotHeldBySlowClients) {
  ServiceOptions o = Sift();
  o.port = 0;
  Server server(o);
  const int port = server.Bind();
  std::thread serving([&] { server.Serve(); });
  Raw slow(port);
  slow.Send("GET /heal");
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const auto t0 = std::chrono::steady_clock::now();
  server.Stop();
  serving.join();
  EXPECT_LT(Seconds(t0), 2.0);
}

// Create, delete and relocalize racing on the same anchors: every answer is 200/201 or 404 (never 500, never a
// crash); a query already running on an anchor being deleted completes with its answer; afterwards the server is
// healthy and a good request keeps its exact answer. (Deleting never waits for or fails on a running query.)
TEST(Service, CreateDeleteAndRelocalizeRaceSafely) {
  const Tum t;
  ServiceOptions o = Sift();
  o.workers = 2;
  const Running s(o);
  httplib::Client c = s.Client();
  const std::string keep = AddAnchor(c, t);
  const std::string good = c.Post(("/v1/anchors/" + keep + "/relocalize").c_str(), Photo(t.query, t.query_depth))->body;
  std::mutex mu;
  std::map<int, int> seen;
  std::vector<std::string> ids;
  for (int round = 0; round < 3; ++round) {
    const std::string id = AddAnchor(c, t);
    std::vector<std::thread> th;
    for (int i = 0; i < 4; ++i)
      th.emplace_back([&, i] {
        httplib::Client cl = s.Client();
        const auto r = i == 3 ? cl.Delete(("/v1/anchors/" + id).c_str())
                              : cl.Post(("/v1/anchors/" + id + "/relocalize").c_str(), Photo(t.query, t.query_depth));
        std::lock_guard<std::mutex> lock(mu);
        ++seen[r ? r->status : -1];
      });
    th.emplace_back([&] {
      httplib::Client cl = s.Client();
      const auto r = cl.Post("/v1/anchors", Photo(t.ref, t.ref_depth));
      std::lock_guard<std::mutex> lock(mu);
      ++seen[r ? r->status : -1];
    });
    for (auto& x : th) x.join();
    EXPECT_EQ(c.Get(("/v1/anchors/" + id).c_str())->status, 404);
  }
  for (const auto& [status, n] : seen)
    EXPECT_TRUE(status == 200 || status == 201 || status == 404) << status << " x" << n;
  EXPECT_EQ(seen[-1], 0);
  EXPECT_EQ(c.Get("/healthz")->status, 200);
  const auto r = c.Post(("/v1/anchors/" + keep + "/relocalize").c_str(), Photo(t.query, t.query_depth));
  ASSERT_TRUE(r);
  EXPECT_EQ(Json::parse(r->body)["tvec"], Json::parse(good)["tvec"]);
}

}  // namespace
}  // namespace freeloc::service
