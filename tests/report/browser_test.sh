#!/usr/bin/env bash
# `freeloc run --report` opened in a real browser: headless Chromium loads index.html from disk with the
# network off; the DOM must list every query, every image must have loaded (the page marks each img loaded or
# broken), no http(s) resource may be referenced; a screenshot is kept in the build folder. Exit 77 (skipped) when
# Chromium is absent. Usage: browser_test.sh FREELOC_BINARY DEMO_DIR OUT_DIR
set -uo pipefail
bin="$1"; demo="$2"; out="$3"
browser="$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)"
if [ -z "$browser" ]; then echo "skipped: Chromium is absent (apt-get install chromium)"; exit 77; fi
fail() { echo "FAIL: $*"; exit 1; }
work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT
"$bin" -q run --data "$demo" --out "$work/sub.zip" --report "$work/report" >/dev/null || fail "run --report"
flags=(--headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking
       --disable-component-update --disable-sync --user-data-dir="$work/profile" --proxy-server=127.0.0.1:9
       --virtual-time-budget=5000)
timeout 120 "$browser" "${flags[@]}" --dump-dom "file://$work/report/index.html" > "$work/dom.html" 2>"$work/chromium.log" \
  || fail "chromium --dump-dom: $(tail -3 "$work/chromium.log")"
grep -q 'data-images="checked"' "$work/dom.html" || fail "the page's image check did not run"
rows=$(grep -o '<tr class="\(ok\|fail\)">' "$work/dom.html" | wc -l)
[ "$rows" -eq 7 ] || fail "expected 7 query rows in the table, found $rows"
imgs=$(grep -o '<img[^>]*>' "$work/dom.html" | wc -l)
loaded=$(grep -o '<img[^>]*data-loaded="1"[^>]*>' "$work/dom.html" | wc -l)
[ "$imgs" -ge 10 ] || fail "expected the 3 CDF plots and 7 detail images, found $imgs images"
[ "$loaded" -eq "$imgs" ] || fail "$((imgs - loaded)) of $imgs images did not load: $(grep -o '<img[^>]*data-broken[^>]*>' "$work/dom.html")"
! grep -qiE '(src|href)="https?:' "$work/dom.html" || fail "the report references the network"
grep -q 's00003 / seq1/frame_00000.png' "$work/dom.html" || fail "no detail view of s00003"
# Every sortable column of every table clicked (up, then down) and its order checked by the page itself.
timeout 120 "$browser" "${flags[@]}" --dump-dom "file://$work/report/index.html#check-sorting" > "$work/sorted.html" \
  2>>"$work/chromium.log" || fail "chromium --dump-dom #check-sorting"
sorting=$(grep -o 'data-sorting="[^"]*"' "$work/sorted.html")
echo "$sorting" | grep -q 'data-sorting="ok [0-9]*"' || fail "sorting: ${sorting:-the check did not run}"
headers=$(grep -o '<table class="sortable"' "$work/dom.html" | wc -l)
# relocalize --report: one pair's report — its row named by the query file, its detail image and 3D view loaded.
s3="$demo/val/s00003"
"$bin" -q relocalize --ref "$s3/seq0/frame_00000.png" --query "$s3/seq1/frame_00000.png" --intrinsics "$s3/intrinsics.txt" \
  --ref-depth "$s3/seq0/frame_00000.sensor.png" --query-depth "$s3/seq1/frame_00000.sensor.png" --report "$work/pair" \
  >/dev/null || fail "relocalize --report"
timeout 120 "$browser" "${flags[@]}" --dump-dom "file://$work/pair/index.html" > "$work/pair.html" 2>>"$work/chromium.log" \
  || fail "chromium --dump-dom (pair report)"
grep -q 'data-images="checked"' "$work/pair.html" || fail "pair report: the page's image check did not run"
[ "$(grep -o '<tr class="ok">' "$work/pair.html" | wc -l)" -eq 1 ] || fail "pair report: expected one solved row"
grep -q '>frame_00000.png</a></td>' "$work/pair.html" || fail "pair report: the row does not name the query file"
pimgs=$(grep -o '<img[^>]*>' "$work/pair.html" | wc -l)
ploaded=$(grep -o '<img[^>]*data-loaded="1"[^>]*>' "$work/pair.html" | wc -l)
[ "$pimgs" -ge 1 ] && [ "$ploaded" -eq "$pimgs" ] || fail "pair report: $ploaded of $pimgs images loaded"
[ -s "$work/pair/q_pair_query.jpg.3d.js" ] || fail "pair report: no 3D view data"
mkdir -p "$out"
timeout 120 "$browser" "${flags[@]}" --window-size=1280,2400 --screenshot="$out/report_screenshot.png" \
  "file://$work/report/index.html" >/dev/null 2>&1 || fail "chromium --screenshot"
[ -s "$out/report_screenshot.png" ] || fail "no screenshot"
echo "ok: $rows query rows, $loaded of $imgs images loaded, the pair report ($ploaded of $pimgs images), $headers sortable tables sorted by every column ($sorting), screenshot $out/report_screenshot.png"
echo "1 passed, 0 failed"
