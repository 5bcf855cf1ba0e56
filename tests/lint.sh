#!/usr/bin/env bash
# make lint: house-style rules that a compiler does not enforce (../shared/STYLE.md).
set -u
cd "$(dirname "$0")/.."
bad=0
report() { echo "lint: $*"; bad=1; }
# 1. no printing, stopping or opening files in the numerics (only src/io does I/O)
while IFS= read -r hit; do report "I/O or stop outside src/io: $hit"; done < <(
  grep -nEi '^\s*(print\b|write\s*\(\s*\*|stop\b|open\s*\()' $(ls src/*/*.f90 src/*/*.inc | grep -v '^src/io/') 2>/dev/null)
# 2. no tab characters in sources
while IFS= read -r f; do report "tab character in $f"; done < <(
  grep -lP '\t' src/*/*.f90 src/*/*.inc src/*/*.c include/*.h tests/*.f90 tests/*.c python/*.f90 2>/dev/null)
# 3. no initialised locals (implicit SAVE): declarations with '=' outside derived-type
#    definitions and module specification parts, excluding parameters
for f in src/*/*.f90 src/*/*.inc; do
  awk -v f="$f" '
    tolower($0) ~ /^[ \t]*(pure |elemental |recursive |impure )*(subroutine|function|(real|integer|logical)[^:]*function)[ \t]/ { inproc++ }
    tolower($0) ~ /^[ \t]*end[ \t]*(subroutine|function)/ { inproc-- }
    tolower($0) ~ /^[ \t]*type[ \t]*(,|::)/ || tolower($0) ~ /^[ \t]*type[ \t]+[a-z_]+[ \t]*$/ { intype = 1 }
    tolower($0) ~ /^[ \t]*end[ \t]*type/ { intype = 0 }
    inproc > 0 && !intype && tolower($0) ~ /^[ \t]*(real|integer|logical|character|type\()[^!]*::[^!]*[^=<>\/]=[^=]/ \
      && tolower($0) !~ /parameter/ { printf "lint: initialised local (implicit save) %s:%d: %s\n", f, NR, $0; bad = 1 }
    END { exit bad }' "$f" || bad=1
done
# 4. no mutable module variables in src/ numerics: 'save' statements
while IFS= read -r hit; do report "save in src/: $hit"; done < <(grep -nEi '^\s*save\b|,\s*save\s*::' $(ls src/*/*.f90 src/*/*.inc | grep -v '^src/io/') 2>/dev/null)
if [ $bad -eq 0 ]; then echo "lint: clean"; fi
exit $bad
