#include "freeloc/eval/run_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "freeloc/core/error.h"
#include "freeloc/eval/view3d.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/image_io.h"

namespace freeloc::eval {

namespace {

// Instance colours (RGB), cycled by instance id.
const cv::Scalar kInstanceColours[] = {{66, 135, 245}, {245, 166, 35}, {171, 71, 188}, {0, 172, 193},
                                       {255, 214, 0},  {236, 64, 122}, {124, 179, 66}, {141, 110, 99}};

cv::Mat ToMat(const Image& im) {
  cv::Mat m(im.height, im.width, CV_8UC3);
  std::copy(im.data.begin(), im.data.end(), m.data);
  return m;
}

// Turbo colour map of the valid depths (2nd–98th percentile), invalid pixels dark grey; `w`×`h`.
cv::Mat DepthColours(const DepthMap& d, int w, int h) {
  cv::Mat out(h, w, CV_8UC3, cv::Scalar(40, 40, 40));
  if (d.empty()) return out;
  std::vector<float> valid;
  for (float v : d.data)
    if (v > 0 && std::isfinite(v)) valid.push_back(v);
  if (valid.empty()) return out;
  std::sort(valid.begin(), valid.end());
  const float lo = valid[valid.size() * 2 / 100], hi = std::max(valid[valid.size() * 98 / 100], lo + 1e-3f);
  cv::Mat gray(d.height, d.width, CV_8UC1), mask(d.height, d.width, CV_8UC1);
  for (int y = 0; y < d.height; ++y)
    for (int x = 0; x < d.width; ++x) {
      const float v = d.at(x, y);
      const bool ok = v > 0 && std::isfinite(v);
      gray.at<uint8_t>(y, x) = ok ? static_cast<uint8_t>(std::clamp((v - lo) / (hi - lo), 0.f, 1.f) * 255) : 0;
      mask.at<uint8_t>(y, x) = ok ? 255 : 0;
    }
  cv::Mat colour, bgr = cv::Mat(d.height, d.width, CV_8UC3, cv::Scalar(40, 40, 40));
  cv::applyColorMap(gray, colour, cv::COLORMAP_TURBO);  // BGR
  cv::cvtColor(colour, colour, cv::COLOR_BGR2RGB);
  colour.copyTo(bgr, mask);
  cv::resize(bgr, out, cv::Size(w, h), 0, 0, cv::INTER_NEAREST);
  return out;
}

std::string Escape(const std::string& s) { return EscapeMarkup(s); }
std::string Num(double v, const char* fmt = "%.3f") { return FormatNumber(fmt, v); }

// Top-down (x, z) plot of the reference camera, the ground-truth and the predicted query centres.
std::string TopDownSvg(const ReportQuery& q) {
  double r = 0.5;
  for (const auto& c : {q.centre, q.gt_centre}) r = std::max({r, std::abs(c.x()), std::abs(c.z())});
  r *= 1.2;
  auto px = [&](double v) { return Num(100 + 90 * v / r, "%.1f"); };
  auto pz = [&](double v) { return Num(100 - 90 * v / r, "%.1f"); };
  std::string s =
      "<svg class=\"top\" width=\"200\" height=\"200\" viewBox=\"0 0 200 200\" "
      "xmlns=\"http://www.w3.org/2000/svg\"><rect width=\"200\" height=\"200\" fill=\"#fafafa\" "
      "stroke=\"#ccc\"/><circle cx=\"100\" cy=\"100\" r=\"4\" fill=\"#33dd66\"/>"
      "<line x1=\"100\" y1=\"100\" x2=\"100\" y2=\"88\" stroke=\"#33dd66\"/>";
  if (q.has_gt)
    s += "<circle cx=\"" + px(q.gt_centre.x()) + "\" cy=\"" + pz(q.gt_centre.z()) +
         "\" r=\"5\" fill=\"none\" stroke=\"#3399ff\" stroke-width=\"2\"><title>ground truth</title></circle>";
  if (q.has_pose)
    s += "<circle cx=\"" + px(q.centre.x()) + "\" cy=\"" + pz(q.centre.z()) +
         "\" r=\"3.5\" fill=\"#ff9922\"><title>predicted</title></circle>";
  s += "<text x=\"4\" y=\"182\" font-size=\"10\" fill=\"#666\">top view (x, z), ±" + Num(r, "%.2f") +
       " m</text><text x=\"4\" y=\"195\" font-size=\"10\" fill=\"#666\"><tspan fill=\"#33dd66\">●</tspan> "
       "reference  <tspan fill=\"#3399ff\">○</tspan> truth  <tspan fill=\"#ff9922\">●</tspan> predicted</text></svg>";
  return s;
}

// The official metrics (names and values as `freeloc eval`), estimates as a percentage.
std::string MetricsTable(const EvalRun& e) {
  const auto v = MetricValues(e.overall);
  // The units of the eight metrics in kMetricNames' order: metres, degrees, pixels, four fractions, a percentage.
  static const char* const kUnits[8] = {"m", "°", "px", "fraction", "fraction", "fraction", "fraction", "%"};
  std::string s = "<table class=\"metrics\"><tr><th>metric</th><th>value</th><th>unit</th></tr>";
  for (int k = 0; k < 8; ++k)
    s += std::string("<tr><td>") + kMetricNames[k] + "</td><td>" +
         Num(k == 7 ? 100 * v[k] : v[k], k == 7   ? "%.1f"
                                         : k == 2 ? "%.2f"
                                                  : "%.4f") +
         "</td><td>" + kUnits[k] + "</td></tr>";
  return s + "</table>";
}

std::string PerSceneTable(const EvalRun& e) {
  std::string s =
      "<table class=\"sortable\"><thead><tr><th>scene</th><th>median t (m)</th><th>median R (°)</th>"
      "<th>median VCRE (px)</th><th>precision (25 cm, 5°)</th><th>estimates</th></tr></thead><tbody>";
  for (const auto& [name, m] : e.per_scene)
    s += "<tr><td>" + Escape(name) + "</td><td>" + Num(m.avg_median_trans, "%.4f") + "</td><td>" +
         Num(m.avg_median_rot, "%.3f") + "</td><td>" + Num(m.avg_median_vcre, "%.2f") + "</td><td>" +
         Num(m.precision_pose, "%.3f") + "</td><td>" + std::to_string(m.estimates) + "</td></tr>";
  return s + "</tbody></table>";
}

std::string Anchor(const ReportQuery& q) {
  std::string a = "q-" + q.scene + "-" + q.frame;
  for (char& c : a)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-') c = '_';
  return a;
}

std::string QueryTable(const std::vector<ReportQuery>& queries) {
  std::string s =
      "<table class=\"sortable\" id=\"queries\"><thead><tr><th>scene</th><th>query</th><th>status</th>"
      "<th>t err (m)</th><th>R err (°)</th><th>VCRE (px)</th><th>confidence</th><th>inliers</th>"
      "<th>matches</th><th>instances used</th></tr></thead><tbody>";
  for (const auto& q : queries) {
    auto err = [&](double v, const char* f) { return q.has_errors ? Num(v, f) : std::string(""); };
    const std::string frame =
        q.visual.empty() ? Escape(q.frame) : "<a href=\"#" + Anchor(q) + "\">" + Escape(q.frame) + "</a>";
    s += "<tr class=\"" + std::string(q.has_pose ? "ok" : "fail") + "\"><td>" + Escape(q.scene) + "</td><td>" + frame +
         "</td><td>" + Escape(q.status) + "</td><td>" + err(q.err.trans_err, "%.4f") + "</td><td>" +
         err(q.err.rot_err, "%.3f") + "</td><td>" + err(q.err.vcre, "%.1f") + "</td><td>" + Num(q.confidence, "%.4g") +
         "</td><td>" + std::to_string(q.inliers) + "</td><td>" + std::to_string(q.matches) + "</td><td>" +
         std::to_string(q.instances_used) + "/" + std::to_string(q.instances) + "</td></tr>";
  }
  return s + "</tbody></table>";
}

std::string Failures(const std::vector<ReportQuery>& queries) {
  std::map<std::string, std::vector<const ReportQuery*>> by;
  for (const auto& q : queries)
    if (!q.has_pose) by[q.status].push_back(&q);
  if (by.empty()) return "<p>Every query has a pose of its own (solved or weak-support).</p>";
  std::string s;
  for (const auto& [status, list] : by) {
    s += "<h3>" + Escape(status) + " (" + std::to_string(list.size()) + ")</h3><ul>";
    for (size_t i = 0; i < list.size() && i < 50; ++i)
      s += "<li>" + Escape(list[i]->scene + "/" + list[i]->frame) +
           (list[i]->message.empty() ? "" : ": " + Escape(list[i]->message)) + "</li>";
    if (list.size() > 50) s += "<li>… and " + std::to_string(list.size() - 50) + " more (see the table)</li>";
    s += "</ul>";
  }
  return s;
}

// Multi-frame: the window's frames and how they voted.
std::string WindowTable(const ReportQuery& q) {
  if (q.window.empty()) return "";
  std::string s = "<p>window: " + Escape(q.window) +
                  "</p><table><tr><th>frame</th><th>status</th><th>tied by</th><th>used</th><th>rotation vote off "
                  "(°)</th><th>depth distance (m)</th></tr>";
  for (const auto& row : q.window_votes) {
    s += "<tr>";
    for (const auto& cell : row) s += "<td>" + Escape(cell) + "</td>";
    s += "</tr>";
  }
  return s + "</table>";
}

std::string Details(const std::string& dir, const std::vector<ReportQuery>& queries) {
  std::vector<const ReportQuery*> shown;
  for (const auto& q : queries)
    if (!q.visual.empty()) shown.push_back(&q);
  // The answers with a pose of their own first, worst first — what there is to learn from; then the unsolved ones
  // (their views are the prior's, alike), worst first among themselves.
  std::stable_sort(shown.begin(), shown.end(), [](const ReportQuery* a, const ReportQuery* b) {
    if (a->has_pose != b->has_pose) return a->has_pose;
    return ReportBadness(*a) > ReportBadness(*b);
  });
  std::string s;
  for (const ReportQuery* q : shown) {
    s += "<div class=\"detail\" id=\"" + Anchor(*q) + "\"><h3>" + Escape(q->scene + " / " + q->frame) + " — " +
         Escape(q->status) + "</h3><p>confidence " + Num(q->confidence, "%.4g") + " · " + std::to_string(q->inliers) +
         " inliers of " + std::to_string(q->matches) + " matches · instances " + std::to_string(q->instances_used) +
         "/" + std::to_string(q->instances) +
         (q->has_errors ? " · t err " + Num(q->err.trans_err, "%.3f m") + " · R err " + Num(q->err.rot_err, "%.2f°") +
                              " · VCRE " + Num(q->err.vcre, "%.1f px")
                        : std::string()) +
         (q->message.empty() ? "" : " · " + Escape(q->message)) + "</p>" + WindowTable(*q) +
         "<div class=\"row\"><img src=\"" + Escape(q->visual) + "\" alt=\"matches and depth of " + Escape(q->frame) +
         "\">" + TopDownSvg(*q) + "</div>" +
         (std::filesystem::exists(dir + "/" + q->visual + ".3d.js")
              ? "<p><button data-view=\"" + Escape(q->visual) +
                    "\" onclick=\"freelocShow3d(this,this.dataset.view)\">3D view</button> the reference's points, its "
                    "camera (green), the predicted (orange) and the "
                    "true (blue) query camera; drag to orbit</p><div class=\"v3d\"></div>"
              : std::string()) +
         "</div>";
  }
  return s;
}

const char kStyle[] =
    "body{font-family:sans-serif;margin:1.5em;color:#222}table{border-collapse:collapse;margin:.5em 0}"
    "td,th{border:1px solid #ddd;padding:3px 8px;font-size:13px;text-align:right}td:first-child,td:nth-child(2),"
    "td:nth-child(3){text-align:left}th{background:#f3f3f3;cursor:pointer}tr.fail{background:#fdecea}"
    ".detail{margin:1em 0;padding:.5em;border-top:1px solid #ccc}.row{display:flex;gap:1em;align-items:flex-start}"
    ".legend span{display:inline-block;width:12px;height:12px;margin:0 4px 0 12px;vertical-align:middle}"
    "img.cdf{width:420px;margin-right:8px}";

// Click a header to sort its own table by its column (numbers numerically, empty cells last); no external script.
// With #check-sorting in the address, the page clicks every sortable header twice once loaded and checks each order
// (ascending, then descending) cell by cell, saying the outcome on <body data-sorting> — the browser test's hook.
const char kScript[] =
    "document.querySelectorAll('table.sortable th').forEach(function(th){th.addEventListener('click',function(){"
    "var i=th.cellIndex,t=th.closest('table'),b=t.tBodies[0],rows=Array.from(b.rows),asc=th.dataset.asc!=='1';"
    "rows.sort(function(a,c){var x=a.cells[i].textContent,y=c.cells[i].textContent,"
    "nx=parseFloat(x),ny=parseFloat(y);if(x===''&&y!=='')return 1;if(y===''&&x!=='')return -1;"
    "var r=(!isNaN(nx)&&!isNaN(ny))?nx-ny:x.localeCompare(y);return asc?r:-r;});"
    "rows.forEach(function(r){b.appendChild(r);});th.dataset.asc=asc?'1':'0';});});"
    // Once everything loaded, mark each image loaded or broken (a missing file shows up in the DOM, and in red).
    "window.addEventListener('load',function(){document.querySelectorAll('img').forEach(function(im){"
    "if(im.complete&&im.naturalWidth>0){im.dataset.loaded='1';}else{im.dataset.broken='1';"
    "im.style.outline='3px solid red';}});document.body.dataset.images='checked';"
    "if(location.hash!=='#check-sorting')return;var bad=[],n=0;"
    "document.querySelectorAll('table.sortable').forEach(function(t,ti){Array.from(t.tHead.rows[0].cells)"
    ".forEach(function(th,ci){[1,-1].forEach(function(dir){th.click();n++;var v=Array.from(t.tBodies[0].rows)"
    ".map(function(r){return r.cells[ci].textContent;});for(var k=1;k<v.length;k++){var a=v[k-1],c=v[k];"
    "if(a===''||c===''){if(a===''&&c!=='')bad.push(ti+':'+th.textContent+' empty first');continue;}"
    "var x=parseFloat(a),y=parseFloat(c),o=(!isNaN(x)&&!isNaN(y))?x-y:a.localeCompare(c);"
    "if(o*dir>0){bad.push(ti+':'+th.textContent+(dir>0?' up':' down'));break;}}});});});"
    "document.body.dataset.sorting=bad.length?'failed: '+bad.join(', '):'ok '+n;});";

}  // namespace

Image DepthColourImage(const DepthMap& depth, int w, int h) {
  if (w <= 0 || h <= 0) w = depth.width, h = depth.height;
  const cv::Mat m = DepthColours(depth, w, h);
  Image out(w, h);
  std::copy(m.data, m.data + out.data.size(), out.data.begin());
  return out;
}

double ReportBadness(const ReportQuery& q) {
  if (!q.has_pose) return std::numeric_limits<double>::infinity();
  if (!q.has_errors) return 0;
  return std::max(q.err.trans_err / 0.25, q.err.rot_err / 5.0);
}

void WriteQueryVisual(const std::string& path, const Image& ref, const Image& query,
                      const std::vector<Eigen::Vector4d>& matches, const std::vector<char>& inlier,
                      const std::vector<int>& source, const DepthMap& depth_ref, const DepthMap& depth_query,
                      const ReportOptions& o) {
  const int pw = std::max(16, o.thumb_width / 2);
  const double sr = static_cast<double>(pw) / std::max(1, ref.width),
               sq = static_cast<double>(pw) / std::max(1, query.width);
  // The matches are in the photos' own pixels; the images may be their working-resolution copies.
  const double mr = static_cast<double>(pw) / std::max(1, ref.PhotoWidth()),
               mq = static_cast<double>(pw) / std::max(1, query.PhotoWidth());
  const int hr = std::max(1, static_cast<int>(std::lround(ref.height * sr)));
  const int hq = std::max(1, static_cast<int>(std::lround(query.height * sq)));
  const int h = std::max(hr, hq), depth_h = (depth_ref.empty() && depth_query.empty()) ? 0 : h / 2;
  cv::Mat canvas(h + depth_h, 2 * pw, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::Mat a, b;
  cv::resize(ToMat(ref), a, cv::Size(pw, hr), 0, 0, cv::INTER_AREA);
  cv::resize(ToMat(query), b, cv::Size(pw, hq), 0, 0, cv::INTER_AREA);
  a.copyTo(canvas(cv::Rect(0, 0, pw, hr)));
  b.copyTo(canvas(cv::Rect(pw, 0, pw, hq)));
  const size_t stride = std::max<size_t>(1, (matches.size() + o.max_lines - 1) / std::max(1, o.max_lines));
  for (size_t i = 0; i < matches.size(); i += stride) {
    const bool in = i < inlier.size() && inlier[i];
    const int src = i < source.size() ? source[i] : -1;
    const cv::Scalar colour = !in        ? cv::Scalar(220, 40, 40)
                              : src >= 0 ? kInstanceColours[src % 8]
                                         : cv::Scalar(30, 170, 60);
    const cv::Point p(static_cast<int>(matches[i](0) * mr), static_cast<int>(matches[i](1) * mr));
    const cv::Point q(pw + static_cast<int>(matches[i](2) * mq), static_cast<int>(matches[i](3) * mq));
    cv::line(canvas, p, q, colour, 1, cv::LINE_AA);
    cv::circle(canvas, p, 2, colour, -1, cv::LINE_AA);
    cv::circle(canvas, q, 2, colour, -1, cv::LINE_AA);
  }
  if (depth_h > 0) {
    const int dw = pw / 2;
    DepthColours(depth_ref, dw, depth_h).copyTo(canvas(cv::Rect(0, h, dw, depth_h)));
    DepthColours(depth_query, dw, depth_h).copyTo(canvas(cv::Rect(pw, h, dw, depth_h)));
  }
  // JPEG (quality 85): a 640 px detail view is ~60 KB, so even 200 of them stay small.
  Image rgb(canvas.cols, canvas.rows);
  canvas.copyTo(cv::Mat(rgb.height, rgb.width, CV_8UC3, rgb.data.data()));
  const std::vector<uint8_t> jpg = io::EncodeJpeg(rgb, 85, path);
  io::WriteFileAtomic(path, jpg.data(), jpg.size());
}

// The detail views' 3D buttons: three.js, OrbitControls and the view script are loaded (script tags work from disk)
// when the first is pressed, then the query's <visual>.3d.js (which sets freelocViews[name]); one view lives at a
// time (browsers allow few WebGL contexts).
const char kScript3d[] =
    "var freelocLive=null;function freelocLoad(src){return new Promise(function(ok,bad){var s=document.createElement("
    "'script');s.src=src;s.onload=ok;s.onerror=function(){bad(new Error(src+' is missing'))};document.head."
    "appendChild(s);});}"
    "async function freelocShow3d(btn,name){var box=btn.parentNode.nextElementSibling;box.style.height='420px';"
    "try{if(typeof freelocView3d==='undefined'){await freelocLoad('three.min.js').catch(function(){});"
    "await freelocLoad('OrbitControls.js').catch(function(){});await freelocLoad('view3d.js');}"
    "window.freelocViews=window.freelocViews||{};if(!freelocViews[name])await freelocLoad(name+'.3d.js');"
    "if(freelocLive){freelocLive.view&&freelocLive.view.dispose();freelocLive.box.innerHTML='';"
    "freelocLive.box.style.height='';}"
    "freelocLive={box:box,view:freelocView3d(box,freelocViews[name])};"
    // No depth map for the reference: the view has the cameras alone, and says so.
    "if(!(freelocViews[name].points||[]).length){var n=document.createElement('p');n.className='note';"
    "n.textContent='No depth map for the reference: the cameras alone, no points.';box.prepend(n);}"
    "}catch(e){box.textContent=e.message;}}";

void WriteRunReport(const std::string& dir, const std::string& title, const std::vector<ReportQuery>& queries,
                    const EvalRun* eval) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  FREELOC_CHECK(std::filesystem::is_directory(dir),
                dir << ": cannot create the report folder (" << ec.message() << ")");
  // The 3D view's scripts beside index.html (three.js copied from libjs-three when it is installed; without it the
  // view says so).
  const std::string view3d = View3dScript();
  io::WriteFileAtomic(dir + "/view3d.js", view3d.data(), view3d.size());
  for (const char* f : {"build/three.min.js", "examples/js/controls/OrbitControls.js"}) {
    const std::filesystem::path from = std::filesystem::path(kThreeJsDir) / f;
    if (std::filesystem::exists(from))
      std::filesystem::copy_file(from, std::filesystem::path(dir) / from.filename(),
                                 std::filesystem::copy_options::overwrite_existing, ec);
  }
  std::string html = "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" + Escape(title) + "</title><style>" +
                     kStyle + "</style></head><body><h1>" + Escape(title) + "</h1>";
  size_t solved = 0, submitted = 0;
  for (const auto& q : queries) solved += q.solved, submitted += q.submitted;
  html += "<p>" + std::to_string(queries.size()) + (queries.size() == 1 ? " query: " : " queries: ") +
          std::to_string(solved) + " solved (status ok), " + std::to_string(submitted) +
          " submitted (solved, or unsolved with a weak-support pose or the prior pose).</p>";
  if (eval) {
    WriteReportDir(dir, {eval});
    html += "<h2>Map-free metrics</h2>" + MetricsTable(*eval) +
            "<p><img class=\"cdf\" src=\"cdf_translation.svg\" alt=\"translation CDF\"><img class=\"cdf\" "
            "src=\"cdf_rotation.svg\" alt=\"rotation CDF\"><img class=\"cdf\" src=\"cdf_vcre.svg\" alt=\"VCRE CDF\">"
            "</p><h2>Scenes</h2>" +
            PerSceneTable(*eval);
  } else {
    html += "<p>No ground truth for these scenes: no metrics.</p>";
  }
  html += "<h2>Queries</h2><p>Click a column to sort; a linked query has a detail view below.</p>" +
          QueryTable(queries) + "<h2>Failures by status</h2>" + Failures(queries) +
          "<h2>Details (worst first)</h2><p class=\"legend\">lines:<span style=\"background:#1eaa3c\"></span>inlier"
          "<span style=\"background:#dc2828\"></span>outlier<span style=\"background:#4287f5\"></span>instance "
          "matches (one colour per instance); depth maps below the photos (turbo: near blue, far red; grey: none); "
          "cameras in the top view and the 3D view:<span style=\"background:#33dd66\"></span>reference"
          "<span style=\"background:#3399ff\"></span>truth<span style=\"background:#ff9922\"></span>predicted"
          "</p>" +
          Details(dir, queries) + "<script>" + kScript + kScript3d + "</script></body></html>\n";
  io::WriteFileAtomic(dir + "/index.html", html.data(), html.size());
}

}  // namespace freeloc::eval
