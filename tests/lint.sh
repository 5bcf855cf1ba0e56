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
# 5. the layers of docs/development.md: a Fortran module uses only modules of its own layer or below
#    (base < models < integrators, parallel < orbits, transport, experiment < workflow < capi < io)
while IFS= read -r hit; do report "layer: $hit"; done < <(awk '
  function layer(d) { return d == "base" ? 0 : d == "models" ? 1 : (d == "integrators" || d == "parallel") ? 2 : \
                      (d == "orbits" || d == "transport" || d == "experiment") ? 3 : d == "workflow" ? 4 : \
                      d == "capi" ? 5 : 6 }
  FNR == 1 { split(FILENAME, p, "/"); dir = p[2] }
  tolower($0) ~ /^[ \t]*module[ \t]+[a-z_0-9]+[ \t]*$/ { m = tolower($2); home[m] = dir }
  tolower($0) ~ /^[ \t]*use[ \t,]/ && tolower($0) !~ /intrinsic/ {
    u = tolower($0); sub(/^[ \t]*use[ \t]*/, "", u); sub(/[ \t,!].*/, "", u)
    n++; uf[n] = FILENAME; ul[n] = FNR; ud[n] = dir; um[n] = u }
  END { for (i = 1; i <= n; i++) if (um[i] in home && layer(home[um[i]]) > layer(ud[i]))
          printf "%s:%d uses %s (src/%s, a higher layer)\n", uf[i], ul[i], um[i], home[um[i]] }' src/*/*.f90)
if [ $bad -eq 0 ]; then echo "lint: clean"; fi
exit $bad
