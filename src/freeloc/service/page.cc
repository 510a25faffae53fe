#include "freeloc/service/page.h"

namespace freeloc::service {

const char* PageHtml() {
  return R"PAGE(<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>freeloc serve</title>
<style>
body{font-family:system-ui,sans-serif;margin:16px;background:#fafafa;color:#222}
h1{font-size:20px;margin:0 0 8px}
section{background:#fff;border:1px solid #ddd;border-radius:6px;padding:10px;margin:8px 0}
.drop{border:2px dashed #aaa;border-radius:6px;padding:10px;text-align:center;color:#666}
.drop.over{border-color:#2a7;color:#2a7}
#status{font-weight:bold} .ok{color:#2a7} .bad{color:#c33}
#pair{max-width:100%;border:1px solid #ccc} #depths img{height:160px;margin-right:8px;border:1px solid #ccc}
#view3d{width:100%;height:420px;border:1px solid #ccc;background:#111}
pre{font-size:11px;max-height:200px;overflow:auto;background:#f4f4f4;padding:6px}
label{margin-right:12px}
</style></head><body>
<h1>freeloc — map-free relocalization</h1>
<section><b>Anchor</b>
 <select id="anchors"></select> <button id="del">delete</button>
 <div class="drop" id="dropA">drop a reference photo here, or <input type="file" id="fileA" accept="image/*"></div>
 <label>depth PNG <input type="file" id="depthA" accept="image/png"></label>
 <label>intrinsics <input id="kA" placeholder="fx,fy,cx,cy (else EXIF / pointmap)" size="30"></label>
 <button id="addA">add anchor</button></section>
<section><b>Query</b>
 <div class="drop" id="dropQ">drop a query photo here, or <input type="file" id="fileQ" accept="image/*"></div>
 <label>depth PNG <input type="file" id="depthQ" accept="image/png"></label>
 <label>intrinsics <input id="kQ" placeholder="fx,fy,cx,cy" size="24"></label>
 <label>true pose <input id="gt" placeholder="qw qx qy qz tx ty tz (optional)" size="34"></label>
 <button id="go">relocalize</button></section>
<section><div id="status">no answer yet</div>
 <canvas id="pair" width="10" height="10"></canvas>
 <div id="depths"></div>
 <div id="view3d"></div>
 <pre id="record"></pre></section>
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
    if (e.dataTransfer.files.length) { set(e.dataTransfer.files[0]); zone.firstChild.textContent = e.dataTransfer.files[0].name + " "; } });
  input.addEventListener("change", () => set(input.files[0]));
}
dropZone($("dropA"), $("fileA"), f => fileA = f);
dropZone($("dropQ"), $("fileQ"), f => fileQ = f);

let linkDepth = null;  // the query's depth in link mode (?query_anchor=): that anchor's uploaded depth PNG
function form(image, depthInput, kText, depthBlob) {
  const f = new FormData(); f.append("image", image);
  if (depthInput && depthInput.files && depthInput.files[0]) f.append("depth", depthInput.files[0]);
  else if (depthBlob) f.append("depth", depthBlob, "depth.png");
  if (kText) f.append("intrinsics", kText);
  return f;
}
$("addA").onclick = async () => {
  if (!fileA) return say("choose a reference photo first", false);
  try { const a = await api("/v1/anchors", {method: "POST", body: form(fileA, $("depthA"), $("kA").value.trim())});
        await loadAnchors(a.id); say("anchor " + a.id + " added (reference work " + a.reference_ms.toFixed(0) + " ms)", true); }
  catch (e) { say(e.message, false); }
};
$("del").onclick = async () => {
  const id = $("anchors").value; if (!id) return;
  try { await api("/v1/anchors/" + id, {method: "DELETE"}); await loadAnchors(); say("anchor " + id + " deleted", true); }
  catch (e) { say(e.message, false); }
};
$("go").onclick = () => relocalize($("anchors").value, fileQ);

function loadImage(src) { return new Promise((ok, bad) => { const i = new Image(); i.onload = () => ok(i); i.onerror = bad; i.src = src; }); }

async function relocalize(id, image) {
  if (!id) return say("add or choose an anchor first", false);
  if (!image) return say("choose a query photo first", false);
  say("relocalizing …", true);
  let rec;
  try { rec = await api("/v1/anchors/" + id + "/relocalize?view=1", {method: "POST", body: form(image, $("depthQ"), $("kQ").value.trim(), linkDepth)}); }
  catch (e) { return say(e.message, false); }
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
  document.body.dataset.answered = rec.status;
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
    g.strokeStyle = inl ? "rgba(40,200,90,0.8)" : "rgba(220,50,50,0.5)";
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
  try { await loadAnchors(params.get("anchor")); } catch (e) { say(e.message, false); }
  // ?anchor=A&query_anchor=B relocalizes B's photo against A at once (a link that shows an answer; the page test).
  const qa = params.get("query_anchor");
  if (params.get("anchor") && qa) {
    try {
      const info = await api("/v1/anchors/" + qa), k = info.intrinsics;  // the photo's intrinsics come along
      if (!$("kQ").value && k.source !== "pointmap") $("kQ").value = [k.fx, k.fy, k.cx, k.cy].join(",");
      if (info.depth) linkDepth = await api("/v1/anchors/" + qa + "/depth?raw=1");
      const blob = await api("/v1/anchors/" + qa + "/image");
      await relocalize(params.get("anchor"), new File([blob], "query.jpg", {type: "image/jpeg"}));
    }
    catch (e) { say(e.message, false); }
  }
})();
</script></body></html>
)PAGE";
}

}  // namespace freeloc::service
