#include "freeloc/service/page.h"

namespace freeloc::service {

namespace {

// The page, one file: markup, style and script (served gzipped, server.cc).
constexpr const char kPageHtml[] = R"PAGE(<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>freeloc serve</title>
<style>
body{font-family:system-ui,sans-serif;margin:16px;background:#fafafa;color:#222}
h1{font-size:20px;margin:0 0 8px}
section{background:#fff;border:1px solid #ddd;border-radius:6px;padding:10px;margin:8px 0}
.drop{border:2px dashed #aaa;border-radius:6px;padding:10px;text-align:center;color:#666}
.drop.over{border-color:#2a7;color:#2a7}
#status{font-weight:bold} .ok{color:#2a7} .bad{color:#c33} .busy{color:#a60}
button:disabled{opacity:.5}
#result{display:none} body.has-answer #result{display:block}
.legend span{display:inline-block;width:12px;height:12px;margin:0 4px 0 12px;vertical-align:middle}
#pair{max-width:100%;border:1px solid #ccc} #depths img{height:160px;margin-right:8px;border:1px solid #ccc}
#view3d{width:100%;height:420px;border:1px solid #ccc;background:#111}
pre{font-size:11px;max-height:200px;overflow:auto;background:#f4f4f4;padding:6px}
label{margin-right:12px}
</style></head><body>
<h1>freeloc — map-free relocalization</h1>
<section><b>Anchor</b>
 <select id="anchors"></select> <button id="del" disabled>delete</button>
 <div class="drop" id="dropA">drop a reference photo here, or <input type="file" id="fileA" accept="image/*"></div>
 <label>depth PNG <input type="file" id="depthA" accept="image/png"></label>
 <label>intrinsics <input id="kA" placeholder="fx,fy,cx,cy (else EXIF / pointmap)" size="30"></label>
 <button id="addA" disabled>add anchor</button></section>
<section><b>Query</b>
 <div class="drop" id="dropQ">drop a query photo here, or <input type="file" id="fileQ" accept="image/*"></div>
 <label>depth PNG <input type="file" id="depthQ" accept="image/png"></label>
 <label>intrinsics <input id="kQ" placeholder="fx,fy,cx,cy" size="24"></label>
 <label>true pose <input id="gt" placeholder="qw qx qy qz tx ty tz (optional)" size="34"></label>
 <button id="go" disabled>relocalize</button></section>
<section><div id="status" class="busy">loading the anchors …</div>
 <div id="result">
 <p class="legend" id="legend">lines:<span style="background:#1eaa3c"></span>inlier<span style="background:#dc2828"></span>outlier;
 depth maps (turbo: near blue, far red; grey: none); cameras in the 3D view:<span style="background:#33dd66"></span>reference
 <span style="background:#3399ff"></span>truth (the true pose, when given)<span style="background:#ff9922"></span>predicted</p>
 <canvas id="pair" width="10" height="10"></canvas>
 <div id="depths"></div>
 <div id="view3d"></div>
 <pre id="record"></pre></div></section>
<script src="/static/three.min.js"></script>
<script src="/static/OrbitControls.js"></script>
<script src="/static/view3d.js"></script>
<script>
"use strict";
const params = new URLSearchParams(location.search);
const token = params.get("token");
const headers = token ? {"Authorization": "Bearer " + token} : {};
const $ = id => document.getElementById(id);
let fileA = null, fileQ = null;

function say(text, ok) { const s = $("status"); s.textContent = text; s.className = ok ? "ok" : "bad"; }
// While a request runs: every button off and the status counting seconds, so that a click is seen to be working.
async function busy(what, work) {
  const buttons = [...document.querySelectorAll("button")], t0 = performance.now(), s = $("status");
  buttons.forEach(b => b.disabled = true);
  const tick = () => { s.textContent = what + " … " + ((performance.now() - t0) / 1000).toFixed(1) + " s"; s.className = "busy"; };
  tick(); const timer = setInterval(tick, 200);
  try { return await work(); } finally { clearInterval(timer); buttons.forEach(b => b.disabled = false); }
}
async function api(path, opts) {
  const r = await fetch(path, Object.assign({headers}, opts || {}));
  const ct = r.headers.get("Content-Type") || "";
  const body = ct.includes("json") ? await r.json() : await r.blob();
  if (!r.ok) throw new Error(r.status + ": " + (body.error || "error"));
  return body;
}
async function loadAnchors(select) {
  const list = (await api("/v1/anchors")).anchors;
  const sel = $("anchors"); sel.innerHTML = "";
  for (const a of list) {
    const o = document.createElement("option"); o.value = a.id;
    o.textContent = a.id + " (" + a.width + "x" + a.height + ", " + a.intrinsics.source + (a.depth ? ", depth" : "") + ")";
    sel.appendChild(o);
  }
  if (select) sel.value = select;
}
function dropZone(zone, input, set) {
  zone.addEventListener("dragover", e => { e.preventDefault(); zone.classList.add("over"); });
  zone.addEventListener("dragleave", () => zone.classList.remove("over"));
  zone.addEventListener("drop", e => { e.preventDefault(); zone.classList.remove("over");
    if (e.dataTransfer.files.length) { input.files = e.dataTransfer.files; set(input.files[0]); } });  // the input names it
  input.addEventListener("change", () => set(input.files[0]));
}
dropZone($("dropA"), $("fileA"), f => fileA = f);
dropZone($("dropQ"), $("fileQ"), f => fileQ = f);

function form(image, depthInput, kText, depthBlob) {
  const f = new FormData(); f.append("image", image);
  if (depthInput && depthInput.files && depthInput.files[0]) f.append("depth", depthInput.files[0]);
  else if (depthBlob) f.append("depth", depthBlob, "depth.png");
  if (kText) f.append("intrinsics", kText);
  return f;
}
$("addA").onclick = async () => {
  if (!fileA) return say("choose a reference photo first", false);
  try { const a = await busy("adding the anchor", () => api("/v1/anchors", {method: "POST", body: form(fileA, $("depthA"), $("kA").value.trim())}));
        await loadAnchors(a.id); say("anchor " + a.id + " added (reference work " + a.reference_ms.toFixed(0) + " ms); now choose a query photo", true); }
  catch (e) { say(e.message, false); }
};
$("del").onclick = async () => {
  const id = $("anchors").value; if (!id) return;
  try { await busy("deleting", () => api("/v1/anchors/" + id, {method: "DELETE"})); await loadAnchors(); say("anchor " + id + " deleted", true); }
  catch (e) { say(e.message, false); }
};
$("go").onclick = () => relocalize($("anchors").value, fileQ);

function loadImage(src) { return new Promise((ok, bad) => { const i = new Image(); i.onload = () => ok(i); i.onerror = bad; i.src = src; }); }

// `linkDepth`: link mode's query depth (the query anchor's uploaded PNG); a query chosen by hand sends its own.
async function relocalize(id, image, linkDepth) {
  if (!id) return say("add or choose an anchor first", false);
  if (!image) return say("choose a query photo first", false);
  let rec;
  try { rec = await busy("relocalizing", () => api("/v1/anchors/" + id + "/relocalize?view=1", {method: "POST", body: form(image, $("depthQ"), $("kQ").value.trim(), linkDepth)})); }
  catch (e) { return say(e.message, false); }
  document.body.classList.add("has-answer");
  const t = rec.tvec.map(v => v.toFixed(3)).join(", ");
  say(rec.status + " — t = (" + t + ")" + (rec.metric ? " m" : " (unit)") + ", confidence " + rec.confidence.toPrecision(3) +
      ", " + rec.inliers + "/" + rec.matches + " inliers, " + rec.service.total_ms.toFixed(0) + " ms", rec.ok);
  const view = rec.view; delete rec.view;
  $("record").textContent = JSON.stringify(rec, null, 1);
  await drawPair(id, view);
  const depths = $("depths"); depths.innerHTML = "";
  const anchorDepth = document.createElement("img"); anchorDepth.alt = "anchor depth"; anchorDepth.src = "/v1/anchors/" + id + "/depth" + (token ? "?token=" + token : "");
  anchorDepth.onerror = () => anchorDepth.remove();
  depths.appendChild(anchorDepth);
  if (view.query_depth) { const q = document.createElement("img"); q.alt = "query depth"; q.src = view.query_depth; depths.appendChild(q); }
  draw3d(view.view3d);
  document.body.dataset.status = rec.status;
}

async function drawPair(id, view) {
  const ref = await loadImage(URL.createObjectURL(await api("/v1/anchors/" + id + "/image")));
  const qry = await loadImage(view.query_image);
  const c = $("pair"), s = Math.min(1, 900 / (ref.width + qry.width));
  c.width = (ref.width + qry.width) * s; c.height = Math.max(ref.height, qry.height) * s;
  const g = c.getContext("2d");
  g.drawImage(ref, 0, 0, ref.width * s, ref.height * s);
  g.drawImage(qry, ref.width * s, 0, qry.width * s, qry.height * s);
  g.lineWidth = 1;
  for (const [xr, yr, xq, yq, inl] of view.matches) {
    g.strokeStyle = inl ? "rgb(30,170,60)" : "rgba(220,40,40,0.6)";  // the report's colours
    g.beginPath(); g.moveTo(xr * s, yr * s); g.lineTo((xq + ref.width) * s, yq * s); g.stroke();
  }
}

function quatToMat(q) { const n = Math.hypot(q[0], q[1], q[2], q[3]), [w, x, y, z] = q.map(v => v / n); return [
  1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
  2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
  2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]; }
let live = null;
function draw3d(view) {
  if (live) live.dispose();
  const gt = $("gt").value.trim().split(/[\s,]+/).map(Number);
  if (gt.length === 7 && gt.every(isFinite) && view.cameras.length > 1)
    view.cameras.push(Object.assign({}, view.cameras[1], {R: quatToMat(gt.slice(0, 4)), t: gt.slice(4), color: "#3399ff", label: "true"}));
  live = freelocView3d($("view3d"), view);
}

(async () => {
  try {
    await loadAnchors(params.get("anchor"));
    const n = $("anchors").options.length;
    say("ready: " + n + (n === 1 ? " anchor" : " anchors") + (n ? "; choose a query photo, or add another anchor" : "; drop a reference photo to add an anchor"), true);
    document.querySelectorAll("button").forEach(b => b.disabled = false);
    document.body.dataset.ready = "1";
  } catch (e) { return say(e.message, false); }
  // ?anchor=A&query_anchor=B relocalizes B's photo against A at once (a link that shows an answer; the page test).
  const qa = params.get("query_anchor");
  if (params.get("anchor") && qa) {
    try {
      const info = await api("/v1/anchors/" + qa), k = info.intrinsics;  // the photo's intrinsics come along
      if (!$("kQ").value && k.source !== "pointmap") $("kQ").value = [k.fx, k.fy, k.cx, k.cy].join(",");
      const depth = info.depth ? await api("/v1/anchors/" + qa + "/depth?raw=1") : null;
      const blob = await api("/v1/anchors/" + qa + "/image?raw=1");  // the file as uploaded, not a re-encoding
      await relocalize(params.get("anchor"), new File([blob], "query", {type: blob.type}), depth);
    }
    catch (e) { say(e.message, false); }
  }
})();
</script></body></html>
)PAGE";

}  // namespace

const char* PageHtml() { return kPageHtml; }

}  // namespace freeloc::service
