#!/bin/bash
# Makes, in a scratch folder, xtensa-esp32s3-elf-* tools that generate REAL ESP32-S3 code (docs/esp32.md,
# "Real ESP32-S3 code"): Debian 13's gcc-xtensa-lx106 13.3 and binutils-xtensa-lx106 2.44 read
# XTENSA_GNU_CONFIG, Espressif's dynamic core configuration; with the ESP32-S3 plugin (built here from
# espressif/xtensa-dynconfig + espressif/xtensa-overlays, as tests/esp32s3-compat-env.sh does) they emit
# the S3's FPU (madd.s, wfr, rfr), 32-bit divide (quos), s32c1i atomics and the windowed ABI.
#   - On Debian 13 (xtensa-lx106-elf-gcc >= 13 installed: apt-get install gcc-xtensa-lx106): the wrappers
#     use it as it is.
#   - Elsewhere (Debian 12): the Debian 13 packages and their libraries are fetched with `apt-get download`
#     through a private apt configuration in SCRATCH_DIR/apt (the system's apt state is left alone),
#     unpacked with `dpkg -x` into SCRATCH_DIR/root, and the interpreter and rpath of every program are
#     pointed there with patchelf. Nothing is installed system-wide. Needs patchelf and Debian 13's
#     archive keyring (debian-archive-keyring on Debian 12 holds it).
# Everything comes from Debian's archive and local clones under $UROS_MIRROR (<owner>+<repo>/repo); nothing
# it writes belongs in this repository.
#
#   UROS_MIRROR=/work/.mirror bash tests/esp32s3-real-env.sh /tmp/esp-real
#   then: PATH=/tmp/esp-real/bin:$PATH UROS_ESP32S3_REAL=1 pytest tests/integration/test_esp32s3_real.py
set -euo pipefail
M=${UROS_MIRROR:?set UROS_MIRROR to the folder of upstream clones}
HERE=$(dirname "$(realpath "$0")")
E=$(realpath -m "${1:?usage: esp32s3-real-env.sh SCRATCH_DIR}")
SUITE=${UROS_DEBIAN13_SUITE:-trixie}
mkdir -p "$E/bin"
cd "$E"

# 1. a GCC >= 13 for xtensa-lx106-elf (the first that reads XTENSA_GNU_CONFIG)
major() { "$1" -dumpversion 2>/dev/null | cut -d. -f1; }
if [ "$(major /usr/bin/xtensa-lx106-elf-gcc || echo 0)" -ge 13 ]; then
  BIN=/usr/bin
else
  BIN=$E/root/usr/bin
  if [ ! -x "$BIN/xtensa-lx106-elf-gcc" ]; then
    A=$E/apt
    mkdir -p "$A/lists/partial" "$A/cache/archives/partial" "$A/debs"
    echo "deb [signed-by=/usr/share/keyrings/debian-archive-keyring.gpg] http://deb.debian.org/debian $SUITE main" \
      > "$A/sources.list"
    O=(-o "Dir::Etc::sourcelist=$A/sources.list" -o Dir::Etc::sourceparts=- -o "Dir::State::Lists=$A/lists"
       -o "Dir::Cache=$A/cache")
    apt-get "${O[@]}" -qq update
    # apt's _apt user cannot write into a folder of root's: the download runs as root (apt warns)
    (cd "$A/debs" && apt-get "${O[@]}" -qq download gcc-xtensa-lx106 binutils-xtensa-lx106 libc6 libstdc++6 \
      libgcc-s1 libisl23 libmpc3 libmpfr6 libgmp10 zlib1g libzstd1 libjansson4 libsframe1 libbinutils)
    rm -rf root
    for deb in "$A"/debs/*.deb; do dpkg -x "$deb" root; done
    LIBS=$E/root/usr/lib/x86_64-linux-gnu:$E/root/lib/x86_64-linux-gnu
    for f in root/usr/bin/xtensa-lx106-elf-* root/usr/lib/gcc/xtensa-lx106-elf/*/* \
             root/usr/libexec/gcc/xtensa-lx106-elf/*/* root/usr/xtensa-lx106-elf/bin/*; do
      # programs and shared objects only (crtbegin.o and the like have no dynamic section)
      [ -f "$f" ] && [ ! -L "$f" ] && patchelf --print-rpath "$f" >/dev/null 2>&1 || continue
      if patchelf --print-interpreter "$f" >/dev/null 2>&1; then
        patchelf --set-interpreter "$E/root/usr/lib64/ld-linux-x86-64.so.2" "$f"
      fi
      patchelf --set-rpath "$LIBS" "$f"
    done
  fi
fi
[ "$(major "$BIN/xtensa-lx106-elf-gcc")" -ge 13 ] || { echo "error: $BIN/xtensa-lx106-elf-gcc is not GCC >= 13" >&2; exit 1; }

# 2. the core plugin (tests/esp32s3-plugin.sh)
. "$HERE/esp32s3-plugin.sh"
build_esp32s3_plugin "$M"

# 3. the wrappers: the S3 core for cc1, gas and ld alike; the binutils beside the compiler first
SO=$E/xtensa-dynconfig/xtensa_esp32s3.so
for t in gcc g++ cpp ar ranlib nm objcopy objdump size ld as readelf strip addr2line; do
  printf '#!/bin/sh\nPATH=%s:$PATH XTENSA_GNU_CONFIG=%s exec %s/xtensa-lx106-elf-%s "$@"\n' "$BIN" "$SO" "$BIN" $t \
    > "bin/xtensa-esp32s3-elf-$t"
  chmod +x "bin/xtensa-esp32s3-elf-$t"
done
ln -sf xtensa-esp32s3-elf-gcc bin/xtensa-esp32s3-elf-cc
echo "PATH=$E/bin:\$PATH  # $("$E/bin/xtensa-esp32s3-elf-gcc" --version | head -1)"
