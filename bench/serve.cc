// bench/serve: a bounded load test of `freeloc serve` on localhost. An in-process server (sift-essential, the bundled
// TUM pair with its sensor depth, one anchor) answers 1, 4 and 16 concurrent clients in turn (M seconds each), each
// sending relocalize requests back to back, while hostile clients hammer it meanwhile (headers a byte at a time, a
// declared 100 GB, garbage bytes, raw bodies, unknown anchors); then a burst against a small queue shows the
// backpressure. Prints per level the latency quantiles, the throughput, the status counts, what the hostile clients
// sent, and the server's memory over the whole run; it stops by itself.
//   usage: build/bench/serve [--clients 1,4,16] [--seconds 30] [--workers 2] [--hostile 4]   (from the repository root)
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench_util.h"
#include "freeloc/io/file_util.h"
#include "freeloc/pipeline/options.h"
#include "freeloc/service/server.h"

// clang-format off
#include <httplib.h>  // after Eigen (through the freeloc headers): OpenSSL's headers, which it pulls, define names Eigen uses
// clang-format on

namespace {

std::string Bytes(const std::string& path) {
  const std::vector<uint8_t> b = freeloc::io::ReadFileBytes(path);
  return std::string(b.begin(), b.end());
}

double RssMiB() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;
  return 0;
}

// One hostile exchange on a raw connection, by kind (0 slow headers, 1 a declared 100 GB, 2 garbage, 3 a raw body,
// 4 an unknown anchor); false when the server's behaviour was not the bounded one expected.
bool Hostile(int port, int kind) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  timeval tv{15, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0) {
    ::close(fd);
    return false;
  }
  const auto send = [&](const std::string& s) { ::send(fd, s.data(), s.size(), MSG_NOSIGNAL); };
  std::string expect;
  switch (kind) {
    case 0:  // a byte every 0.5 s: closed by the server's header time limit (10 s)
      for (const char* p = "GET /healthz HTTP/1.1\r\n"; *p; ++p) {
        send(std::string(1, *p));
        std::this_thread::sleep_for(std::chrono::milliseconds(500));
      }
      break;
    case 1:
      send(
          "POST /v1/anchors HTTP/1.1\r\nContent-Type: multipart/form-data; boundary=b\r\nContent-Length: "
          "100000000000\r\n\r\n0123456789");
      expect = "413";
      break;
    case 2:
      send(std::string("\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03 garbage\r\n\r\n", 28));
      expect = "400";
      break;
    case 3:
      send("POST /v1/anchors HTTP/1.1\r\nContent-Type: image/png\r\nContent-Length: 5\r\n\r\nhello");
      expect = "415";
      break;
    default: send("GET /v1/anchors/nope HTTP/1.1\r\nConnection: close\r\n\r\n"); expect = "404";
  }
  std::string got;
  char buf[4096];
  for (ssize_t n; (n = ::recv(fd, buf, sizeof(buf), 0)) > 0;) got.append(buf, static_cast<size_t>(n));
  ::close(fd);
  return expect.empty() ? got.find("HTTP/1.1 200") == std::string::npos : got.rfind("HTTP/1.1 " + expect, 0) == 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::signal(SIGPIPE, SIG_IGN);
  std::vector<int> levels = {1, 4, 16};
  int workers = 2, hostile = 4;
  double seconds = 30;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--clients")) {
      levels.clear();
      std::stringstream ss(argv[i + 1]);
      for (std::string v; std::getline(ss, v, ',');) levels.push_back(std::max(1, std::atoi(v.c_str())));
    }
    if (!std::strcmp(argv[i], "--seconds")) seconds = std::atof(argv[i + 1]);
    if (!std::strcmp(argv[i], "--workers")) workers = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--hostile")) hostile = std::atoi(argv[i + 1]);
  }
  const int clients = *std::max_element(levels.begin(), levels.end());
  const std::string s = "data/demo/val/s00003/";
  const std::string ref = Bytes(s + "seq0/frame_00000.png"), query = Bytes(s + "seq1/frame_00000.png");
  const std::string ref_d = Bytes(s + "seq0/frame_00000.sensor.png"),
                    query_d = Bytes(s + "seq1/frame_00000.sensor.png");
  const std::string k = "520.908620,521.007327,325.141442,249.701764";
  const auto form = [&](const std::string& image, const std::string& depth) {
    return httplib::MultipartFormDataItems{
        {"image", image, "i.png", "image/png"}, {"depth", depth, "d.png", "image/png"}, {"intrinsics", k, "", ""}};
  };

  freeloc::service::ServiceOptions o;
  o.pipeline = freeloc::pipeline::ResolvePreset("sift-essential");
  o.port = 0;
  o.workers = workers;
  o.max_queue = std::max(clients, 1);
  freeloc::service::Server server(o);
  const int port = server.Bind();
  std::thread serving([&] { server.Serve(); });
  httplib::Client admin("127.0.0.1", port);
  const auto created = admin.Post("/v1/anchors", form(ref, ref_d));
  if (!created || created->status != 201) {
    std::fprintf(stderr, "serve: could not add the anchor\n");
    server.Stop();
    serving.join();
    return 1;
  }
  const std::string id = created->body.substr(created->body.find("\"id\":\"") + 6, 16);
  const std::string path = "/v1/anchors/" + id + "/relocalize";

  std::printf("# bench/serve\n\n%s\n\n", freeloc::bench::MachineLine().c_str());
  std::printf(
      "sift-essential with sensor depth, one anchor (TUM s00003), %d workers; each level: its clients for %.0f s, each "
      "sending the next request when the last is answered, and %d hostile clients meanwhile (headers a byte every "
      "0.5 s, a declared 100 GB, garbage bytes, raw bodies, unknown anchors, in turn); server and clients in one "
      "process.\n\n",
      workers, seconds, hostile);
  std::printf(
      "| clients | requests | answered 200 | other statuses | p50 ms | p95 ms | p99 ms | throughput /s | hostile "
      "exchanges | hostile answered as bounded |\n|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|\n");
  const double run0 = freeloc::bench::NowSeconds();
  std::vector<std::pair<double, double>> rss{{0, RssMiB()}};
  for (const int level : levels) {
    std::mutex mu;
    std::vector<double> latencies;
    std::map<int, int> statuses;
    std::atomic<bool> stop{false};
    std::atomic<int> hostile_sent{0}, hostile_ok{0};
    const double t0 = freeloc::bench::NowSeconds();
    std::vector<std::thread> threads;
    for (int c = 0; c < level; ++c)
      threads.emplace_back([&] {
        httplib::Client cl("127.0.0.1", port);
        cl.set_read_timeout(300, 0);
        while (!stop) {
          const double a = freeloc::bench::NowSeconds();
          const auto r = cl.Post(path.c_str(), form(query, query_d));
          const double ms = 1000 * (freeloc::bench::NowSeconds() - a);
          std::lock_guard<std::mutex> lock(mu);
          ++statuses[r ? r->status : -1];
          if (r && r->status == 200) latencies.push_back(ms);
        }
      });
    for (int h = 0; h < hostile; ++h)
      threads.emplace_back([&, h] {
        for (int k = h; !stop; ++k) {
          hostile_ok += Hostile(port, k % 5);
          ++hostile_sent;
        }
      });
    while (freeloc::bench::NowSeconds() - t0 < seconds) {
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
      const double t = freeloc::bench::NowSeconds() - run0;
      if (t - rss.back().first >= 10) rss.emplace_back(t, RssMiB());
    }
    stop = true;
    for (auto& t : threads) t.join();
    const double elapsed = freeloc::bench::NowSeconds() - t0;
    std::sort(latencies.begin(), latencies.end());
    const auto q = [&](double p) {
      return latencies.empty() ? 0.0
                               : latencies[std::min(latencies.size() - 1, static_cast<size_t>(p * latencies.size()))];
    };
    int total = 0;
    std::string other;
    for (const auto& [st, n] : statuses) {
      total += n;
      if (st != 200) other += (other.empty() ? "" : ", ") + std::to_string(st) + ": " + std::to_string(n);
    }
    std::printf("| %d | %d | %d | %s | %.1f | %.1f | %.1f | %.2f | %d | %d |\n", level, total, statuses[200],
                other.empty() ? "none" : other.c_str(), q(0.5), q(0.95), q(0.99), statuses[200] / elapsed,
                hostile_sent.load(), hostile_ok.load());
    std::fflush(stdout);
  }
  rss.emplace_back(freeloc::bench::NowSeconds() - run0, RssMiB());
  std::printf("\nMemory (resident, MiB) over the run:\n\n| t (s) |");
  for (const auto& [t, m] : rss) std::printf(" %.0f |", t);
  std::printf("\n|---|");
  for (size_t i = 0; i < rss.size(); ++i) std::printf("---:|");
  std::printf("\n| RSS |");
  for (const auto& [t, m] : rss) std::printf(" %.0f |", m);
  std::printf("\n\n");
  std::mutex mu;

  // Backpressure: a new server with 1 worker and a queue of 2, hit by a burst of 4 x clients at once.
  server.Stop();
  serving.join();
  o.workers = 1;
  o.max_queue = 2;
  freeloc::service::Server small(o);
  const int port2 = small.Bind();
  std::thread serving2([&] { small.Serve(); });
  httplib::Client admin2("127.0.0.1", port2);
  const auto created2 = admin2.Post("/v1/anchors", form(ref, ref_d));
  const std::string path2 =
      "/v1/anchors/" + created2->body.substr(created2->body.find("\"id\":\"") + 6, 16) + "/relocalize";
  std::map<int, int> burst;
  std::map<std::string, int> failures;  // client-side: no HTTP answer
  std::vector<std::thread> b;
  const int n = 4 * std::max(clients, 1);
  for (int i = 0; i < n; ++i)
    b.emplace_back([&] {
      httplib::Client cl("127.0.0.1", port2);
      cl.set_read_timeout(300, 0);
      cl.set_write_timeout(300, 0);  // a connection beyond the server's threads waits, unread, until one takes it
      const auto r = cl.Post(path2.c_str(), form(query, query_d));
      std::lock_guard<std::mutex> lock(mu);
      ++burst[r ? r->status : -1];
      if (!r) ++failures[httplib::to_string(r.error())];
    });
  for (auto& t : b) t.join();
  small.Stop();
  serving2.join();
  std::printf(
      "Backpressure: a burst of %d simultaneous requests against 1 worker and a queue of 2:\n\n| status | "
      "requests |\n|---|---:|\n",
      n);
  for (const auto& [st, c] : burst) std::printf("| %d | %d |\n", st, c);
  for (const auto& [what, c] : failures) std::printf("\n(-1: no HTTP answer: %s, %d)", what.c_str(), c);
  std::printf("\n");
  return 0;
}
