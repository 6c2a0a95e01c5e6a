#!/usr/bin/env bash
# `autocal distortion` on still images: twenty shots of a simulated office through the
# sonnar lens (k1 = -0.3, k2 = 0.1), starting from the true focal length and principal
# point with no distortion; plus its errors and exit codes.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
source "$(dirname "$0")/common.bash"

"$autocal" simulate --scenario office --lens sonnar --seconds 4 --resolution 640x480 \
  --out "$dir/rec" >/dev/null 2>&1
mkdir "$dir/stills"
ls "$dir/rec/cam0/data" | awk 'NR % 6 == 1' | while read -r f; do cp "$dir/rec/cam0/data/$f" "$dir/stills/"; done

IFS=, read -r _ fx fy cx cy _ <<<"$(sed -n 2p "$dir/rec/ground_truth/intrinsics.csv")"
write_calibration "$dir/prior.yaml" 640 480 "$fx" "$fy" "$cx" "$cy"

"$autocal" distortion --images "$dir/stills/*.png" --prior "$dir/prior.yaml" \
  --summary "$dir/summary.json" --out "$dir/estimate.yaml" 2>"$dir/progress"
cat "$dir/summary.json"
grep -q '20/20 images (100%)' "$dir/progress" || fail "progress shown"
grep -q '"usable": true' "$dir/summary.json" || fail "usable estimate"
# The estimate, read back from the OpenCV file it wrote.
coefficients=$(awk '/distortion_coefficients/ {found = 1} found && /data:/ {gsub(/[][,]/, " "); print $2, $3; exit}' "$dir/estimate.yaml")
read -r k1 k2 <<<"$coefficients"
awk -v k1="$k1" -v k2="$k2" 'BEGIN { exit !((k1 + 0.3) ^ 2 < 0.005 ^ 2 && (k2 - 0.1) ^ 2 < 0.01 ^ 2) }' ||
  fail "k1=$k1 k2=$k2, expected -0.3 +- 0.005 and 0.1 +- 0.01"
after=$(awk -F': ' '/"rms_after_px"/ {gsub(/,/, "", $2); print $2}' "$dir/summary.json")
awk -v a="$after" 'BEGIN { exit !(a < 0.2) }' || fail "straightness after $after px"

# Errors: nothing matches; a file that is no image (named); a prior for another size.
set +e
"$autocal" distortion --images "$dir/none/*.png" 2>"$dir/err"; code=$?
set -e
[[ $code -eq 2 ]] || fail "no match exits $code, expected 2"
echo "not an image" >"$dir/stills/zz_broken.png"
set +e
"$autocal" distortion --images "$dir/stills/*.png" --prior "$dir/prior.yaml" 2>"$dir/err"; code=$?
set -e
[[ $code -eq 1 ]] || fail "broken image exits $code"
grep -q "zz_broken.png" "$dir/err" || fail "broken image named: $(cat "$dir/err")"
rm "$dir/stills/zz_broken.png"
sed -i 's/image_width: 640/image_width: 320/' "$dir/prior.yaml"
set +e
"$autocal" distortion --images "$dir/stills/*.png" --prior "$dir/prior.yaml" 2>"$dir/err"; code=$?
set -e
[[ $code -eq 1 ]] || fail "size mismatch exits $code"
grep -q "320x480 images, the images are 640x480" "$dir/err" || fail "size mismatch explained: $(cat "$dir/err")"
echo "distortion: all checks passed"
