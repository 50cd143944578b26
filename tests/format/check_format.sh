#!/usr/bin/env bash
# Fails when a tracked C++ file differs from what clang-format makes of it (the repository's .clang-format),
# naming each such file and the command that fixes them all.
#   check_format.sh CLANG_FORMAT SOURCE_DIR
set -euo pipefail
clang_format=$1
cd "$2"
mapfile -t files < <(git ls-files '*.cc' '*.h')
(( ${#files[@]} > 0 )) || { echo "no tracked C++ files under $2 (not a git checkout?)"; exit 1; }
unformatted=()
for file in "${files[@]}"; do
  "$clang_format" --dry-run --Werror "$file" >/dev/null 2>&1 || unformatted+=("$file")
done
if (( ${#unformatted[@]} )); then
  printf 'not formatted: %s\n' "${unformatted[@]}"
  echo "${#unformatted[@]} of ${#files[@]} files; fix with: git ls-files '*.cc' '*.h' | xargs $clang_format -i"
  exit 1
fi
echo "${#files[@]} files formatted as .clang-format says"
