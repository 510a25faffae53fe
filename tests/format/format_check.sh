#!/usr/bin/env bash
# The C++ sources are formatted with the repository's .clang-format (`make format` rewrites them). Lists the files
# that differ and fails; skipped (exit 77) where clang-format is not installed (scripts/install-deps.sh installs it).
set -uo pipefail
cd "$1" || exit 1
command -v clang-format >/dev/null || { echo "clang-format not found: skipped"; exit 77; }
mapfile -t files < <(find src bench tests python/src fuzz \( -name '*.cc' -o -name '*.h' \) \
  -not -path '*/corpus/*' -not -path '*/regressions/*' | sort)
bad=()
for f in "${files[@]}"; do
  clang-format --dry-run -Werror "$f" >/dev/null 2>&1 || bad+=("$f")
done
if ((${#bad[@]})); then
  printf 'not formatted (run `make format`): %s\n' "${bad[@]}"
  exit 1
fi
echo "${#files[@]} files formatted"
