#!/usr/bin/env bash
# The README, docs/ and bench/README.md speak of the product: what it does and why, never
# the development sessions it was built in. Measured figures go to docs/validation.md.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.bash"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
if found=$(grep -n -iE '\bsessions? [0-9]+' "$root/README.md" "$root"/docs/*.md "$root/bench/README.md"); then
  fail "development sessions narrated: $found"
fi
echo PASS
