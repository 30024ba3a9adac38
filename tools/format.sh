#!/usr/bin/env bash
# Formats the project's C and C++ sources with clang-format 14 and .clang-format.
#
#   tools/format.sh           reformat every tracked .c/.cpp/.h file in place
#   tools/format.sh --check   change nothing; list the files that differ and exit 1 if any
#
# The files are git's tracked ones (or, outside a git checkout, every .c/.cpp/.h below the
# source folders). Needs clang-format-14 (Debian: apt install clang-format-14).
set -euo pipefail
cd "$(dirname "$0")/.."
check=0
case "${1:-}" in
  --check) check=1 ;;
  "") ;;
  *) echo "usage: tools/format.sh [--check]" >&2; exit 2 ;;
esac
format=$(command -v clang-format-14 || true)
[ -n "$format" ] || { echo "tools/format.sh: clang-format-14 not found (apt install clang-format-14)" >&2; exit 2; }
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files '*.c' '*.cpp' '*.h')
else
  mapfile -t files < <(find bake bench core runtime samples tests tools -name node_modules -prune -o \
                            \( -name '*.c' -o -name '*.cpp' -o -name '*.h' \) -print | sort)
fi
if [ "$check" -eq 0 ]; then
  "$format" --style=file -i "${files[@]}"
  exit 0
fi
differ=0
for f in "${files[@]}"; do
  if ! "$format" --style=file "$f" | cmp -s - "$f"; then
    echo "tools/format.sh: $f is not formatted (run tools/format.sh)"
    differ=1
  fi
done
[ "$differ" -eq 0 ] && echo "tools/format.sh: ${#files[@]} files formatted"
exit "$differ"
