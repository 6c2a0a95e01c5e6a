#!/usr/bin/env bash
# Builds the .deb with CPack and checks it: control fields and Depends, the files it
# installs, and that the commands and man pages it holds work once extracted into a
# temporary folder. Nothing is installed on this machine.
# Usage: package_test.sh BUILD_DIR VERSION SOURCE_UDEV_RULES
set -euo pipefail

build=$1
version=$2
rules=$3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

fail() {
  echo "FAIL: $*" >&2
  exit 1
}

cpack --config "$build/CPackConfig.cmake" -B "$tmp/out" > "$tmp/cpack.log" 2>&1 ||
  { cat "$tmp/cpack.log" >&2; fail "cpack failed"; }
debs=("$tmp"/out/*.deb)
[[ ${#debs[@]} -eq 1 && -f ${debs[0]} ]] || fail "expected one .deb, got: ${debs[*]}"
deb=${debs[0]}
echo "package: $(basename "$deb") ($(stat -c %s "$deb") bytes)"

# Control fields.
field() { dpkg-deb -f "$deb" "$1"; }
[[ $(field Package) == autocal ]] || fail "Package is '$(field Package)'"
[[ $(field Version) == "$version" ]] || fail "Version is '$(field Version)', not $version"
[[ $(field Architecture) == "$(dpkg --print-architecture)" ]] || fail "Architecture '$(field Architecture)'"
depends=$(field Depends)
echo "Depends: $depends"
# What the binaries link, found by dpkg-shlibdeps: each must be a dependency.
tr ',' '\n' <<< "$depends" | awk '{print $1}' > "$tmp/depends"
for package in libc6 libstdc++6 libqt5core5a libqt5widgets5 libqt5charts5 libqt5svg5 \
  libsqlite3-0 libusb-1.0-0 libopencv-core406 libopencv-calib3d406; do
  grep -qxF "$package" "$tmp/depends" || fail "Depends lacks $package"
done

# Files.
dpkg-deb -c "$deb" | awk '{print $6}' > "$tmp/files"
for path in ./usr/bin/autocal ./usr/bin/autocal-workbench \
  ./usr/share/applications/autocal-workbench.desktop \
  ./usr/share/icons/hicolor/scalable/apps/autocal.svg \
  ./lib/udev/rules.d/99-autocal.rules \
  ./usr/share/man/man1/autocal.1.gz ./usr/share/man/man1/autocal-workbench.1.gz \
  ./usr/share/autocal/scenarios/office.yaml; do
  grep -qx "$path" "$tmp/files" || fail "the package lacks $path"
done
# Nothing lands under /usr/local or in the build tree's paths.
if grep -Eq '^\./usr/local/|/work/|/tmp/' "$tmp/files"; then fail "stray paths: $(grep -E '^\./usr/local/|/work/|/tmp/' "$tmp/files")"; fi

# The extracted commands run and say their version.
dpkg-deb -x "$deb" "$tmp/root"
[[ $("$tmp/root/usr/bin/autocal" --version) == "autocal $version" ]] || fail "autocal --version"
[[ $("$tmp/root/usr/bin/autocal-workbench" --version) == "autocal-workbench $version" ]] ||
  fail "autocal-workbench --version"
"$tmp/root/usr/bin/autocal" simulate --list > /dev/null || fail "autocal simulate --list"
# Stripped: no debug sections left.
if objdump -h "$tmp/root/usr/bin/autocal-workbench" | grep -q '\.debug_info'; then
  fail "autocal-workbench is not stripped"
fi

# The udev rules are the ones in the source tree.
cmp "$rules" "$tmp/root/lib/udev/rules.d/99-autocal.rules" || fail "udev rules differ"

# The desktop entry starts the workbench with the packaged icon.
desktop=$tmp/root/usr/share/applications/autocal-workbench.desktop
grep -qx 'Exec=autocal-workbench %f' "$desktop" || fail "desktop entry Exec"
grep -qx 'Icon=autocal' "$desktop" || fail "desktop entry Icon"
if command -v desktop-file-validate > /dev/null; then desktop-file-validate "$desktop"; fi

# Man pages: the version, and a section for every command `autocal --help` lists.
man1=$tmp/root/usr/share/man/man1
zcat "$man1/autocal.1.gz" | grep -q "^\.TH AUTOCAL 1 .*autocal $version" || fail "autocal.1 .TH"
commands=$("$tmp/root/usr/bin/autocal" --help | sed -n '/^commands:/,$p' | awk 'NR > 1 && NF {print $1}')
[[ -n $commands ]] || fail "autocal --help lists no commands"
for command in $commands; do
  zcat "$man1/autocal.1.gz" | grep -qx "\.SS $command" || fail "autocal.1 has no section for $command"
done
zcat "$man1/autocal-workbench.1.gz" | grep -q -- '--history' || fail "autocal-workbench.1 lacks --history"
if command -v man > /dev/null; then
  MANWIDTH=80 man -l "$man1/autocal.1.gz" 2> "$tmp/man.err" > /dev/null
  [[ ! -s $tmp/man.err ]] || { cat "$tmp/man.err" >&2; fail "man warns on autocal.1"; }
fi
echo "package OK: $(grep -c . "$tmp/files") paths; commands: $(echo $commands)"
