#!/usr/bin/env bash
# The stage-SDK measures of issue 15 (specs/stage-sdk.md, "Measures of done"), for a commit or
# for the working tree, so that the before/after numbers can be regenerated:
#   1. per stage folder (a folder holding a stage.h): its source files (tests excluded) and their
#      non-blank lines, split into kernel.h (the per-element physics) and the rest (ceremony:
#      declaration, registration, loops, plugin.cpp, CMake); per library, the files outside any
#      stage folder (plugin.cpp, aliases.cpp, CMakeLists.txt, shared headers);
#   2. the virtual member functions of Stage (destructor excluded);
#   3. the preprocessor conditionals on FLIPFLOW_HAVE_CUDA;
#   4. the 10 largest source files.
# Lines: "lines" = non-blank lines, "code" = non-blank lines that are not comments (// or /* */
# in C++ and CUDA, # in CMake).
#
# usage: bench/sdk-measures.sh [REV]
#   REV given: the files of that commit (git ls-tree); none: the working tree (tracked and
#   untracked files git does not ignore, so build folders are left out).
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"
rev=${1:-}

files() {
  if [ -n "$rev" ]; then
    git ls-tree -r --name-only "$rev"
  else
    git ls-files -co --exclude-standard | while IFS= read -r f; do [ -f "$f" ] && printf '%s\n' "$f"; done
  fi | grep -v '^bench/experiments/' | sort -u
}
show() { if [ -n "$rev" ]; then git show "$rev:$1"; else cat -- "$1"; fi; }

# "lines code" of one file.
count() {
  show "$1" | awk -v cmake="$([[ $1 == *CMakeLists.txt || $1 == *.cmake ]] && echo 1 || echo 0)" '
    { s = $0; sub(/^[ \t]+/, "", s) }
    s == "" { next }
    { lines++ }
    cmake == 1 { if (s !~ /^#/) code++; next }
    inblock { if (s ~ /\*\//) inblock = 0; next }
    s ~ /^\/\// { next }
    s ~ /^\/\*/ { if (s !~ /\*\//) inblock = 1; next }
    { code++ }
    END { printf "%d %d\n", lines + 0, code + 0 }'
}

all=$(files)
sources=$(grep -E '\.(h|hpp|cpp|cu|cuh)$|(^|/)CMakeLists\.txt$|\.cmake$' <<<"$all" || true)
is_test() { [[ $(basename "$1") == test_* ]]; }

echo "# stage-SDK measures: ${rev:-working tree} ($(git rev-parse --short "${rev:-HEAD}")${rev:+}$([ -z "$rev" ] && echo ' + uncommitted changes'), $(date -u +%Y-%m-%dT%H:%MZ))"
echo
echo "## 1. Ceremony per stage folder (tests excluded)"
echo
echo "| stage folder | files | lines | code | kernel.h lines (code) | ceremony lines (code) | ceremony files |"
echo "| --- | ---: | ---: | ---: | ---: | ---: | --- |"
stage_dirs=$(grep -E '^(stages|plugins)/.*stage\.h$' <<<"$sources" | xargs -n1 dirname | sort -u)
tf=0; tl=0; tc=0; cl=0; cc=0; ns=0
for d in $stage_dirs; do
  nf=0; l=0; c=0; kl=0; kc=0; names=""
  for f in $(grep -E "^$d/[^/]+$" <<<"$sources"); do
    is_test "$f" && continue
    read -r a b < <(count "$f")
    nf=$((nf + 1)); l=$((l + a)); c=$((c + b))
    if [ "$(basename "$f")" = kernel.h ]; then kl=$a; kc=$b; else names="$names $(basename "$f")"; fi
  done
  echo "| $d | $nf | $l | $c | $kl ($kc) | $((l - kl)) ($((c - kc))) |$names |"
  ns=$((ns + 1)); tf=$((tf + nf)); tl=$((tl + l)); tc=$((tc + c)); cl=$((cl + l - kl)); cc=$((cc + c - kc))
done
echo "| **all $ns stages** | $tf | $tl | $tc | $((tl - cl)) ($((tc - cc))) | $cl ($cc) | |"
echo
echo "Per library, the files outside its stage folders (tests and docs excluded):"
echo
echo "| library | files | lines (code) | files |"
echo "| --- | ---: | ---: | --- |"
for lib in $(grep -E '^(stages|plugins)/[^/]+/' <<<"$sources" | cut -d/ -f1,2 | sort -u); do
  nf=0; l=0; c=0; names=""
  for f in $(grep -E "^$lib/" <<<"$sources"); do
    is_test "$f" && continue
    in_stage=0
    for d in $stage_dirs; do [ "$(dirname "$f")" = "$d" ] && in_stage=1; done
    [ $in_stage = 1 ] && continue
    read -r a b < <(count "$f")
    nf=$((nf + 1)); l=$((l + a)); c=$((c + b)); names="$names ${f#$lib/}"
  done
  echo "| $lib | $nf | $l ($c) |$names |"
done
echo
stage_h=$(grep -E '^core/(stage/)?stage\.h$' <<<"$sources" | head -1)
echo "## 2. Virtual member functions of Stage ($stage_h, destructor excluded)"
echo
show "$stage_h" | awk '/^class Stage/ {on = 1} on && /^};/ {on = 0} on && /virtual/ && !/~Stage/' |
  sed -E 's/^ +/    /'
echo
echo "count: $(show "$stage_h" | awk '/^class Stage/ {on = 1} on && /^};/ {on = 0} on && /virtual/ && !/~Stage/' | wc -l)"
echo
echo "## 3. Preprocessor conditionals on FLIPFLOW_HAVE_CUDA (C++/CUDA sources)"
echo
n_ifdef=0; n_ifdefined=0; n_other=0; filesn=0
for f in $(grep -E '\.(h|hpp|cpp|cu|cuh)$' <<<"$sources"); do
  t=$(show "$f")
  a=$(grep -cE '^\s*#\s*ifdef\s+FLIPFLOW_HAVE_CUDA' <<<"$t" || true)
  b=$(grep -cE '^\s*#\s*if\s+defined\(FLIPFLOW_HAVE_CUDA\)' <<<"$t" || true)
  o=$(grep -E '^\s*#\s*(if|elif|ifndef)' <<<"$t" | grep -vE '^\s*#\s*ifdef|^\s*#\s*if\s+defined\(FLIPFLOW_HAVE_CUDA\)' | grep -c FLIPFLOW_HAVE_CUDA || true)
  n_ifdef=$((n_ifdef + a)); n_ifdefined=$((n_ifdefined + b)); n_other=$((n_other + o))
  [ $((a + b + o)) -gt 0 ] && filesn=$((filesn + 1))
done
echo "- \`#ifdef FLIPFLOW_HAVE_CUDA\`: $n_ifdef"
echo "- \`#if defined(FLIPFLOW_HAVE_CUDA)\` (alone or combined): $n_ifdefined"
echo "- other conditionals naming it (\`#ifndef\`, \`#if !defined\`, \`#elif\`): $n_other"
echo "- in $filesn files"
echo
echo "## 4. The 10 largest source files (.h .cpp .cu .cuh; all lines)"
echo
echo "| lines | file |"
echo "| ---: | --- |"
for f in $(grep -E '\.(h|hpp|cpp|cu|cuh)$' <<<"$sources"); do
  echo "$(show "$f" | wc -l) $f"
done | sort -rn | head -10 | awk '{printf "| %d | %s |\n", $1, $2}'
