#!/bin/bash
# Builds, in a scratch folder, a qemu-system-xtensa that knows an ESP32-S3 CPU (`-cpu esp32s3`), for the
# ESP32-S3 probe board (docs/esp32.md, "An ESP32-S3 core in QEMU"):
#   1. Debian's own qemu source package for this system's release (`apt-get source qemu` through a private
#      apt configuration in SCRATCH_DIR/apt with a deb-src line: the system's apt state is left alone);
#   2. QEMU's own target/xtensa/import_core.sh over the ESP32-S3 core of espressif/xtensa-overlays (a local
#      clone under $UROS_MIRROR); the overlay has no xtensa/config/core-matmap.h, which only MPU cores use:
#      a file with an include guard stands in for it;
#   3. one edit of the generated core-esp32s3.c: it lists only the core opcodes, so the FPU translators are
#      added (as QEMU's core-de233_fpu.c has them), else `wfr` is an illegal instruction;
#   4. configure for xtensa-softmmu only, and ninja qemu-system-xtensa (nice'd, -j from UROS_QEMU_JOBS).
# The only system-wide change is `apt-get install` of the build dependencies (libglib2.0-dev,
# libpixman-1-dev, ninja-build, dpkg-dev). Nothing it writes belongs in this repository.
#
#   UROS_MIRROR=/work/.mirror bash tests/esp32s3-qemu-env.sh /tmp/esp-qemu
#   then: UROS_ESP32S3_QEMU=/tmp/esp-qemu/bin/qemu-system-xtensa (docs/esp32.md)
set -euo pipefail
M=${UROS_MIRROR:?set UROS_MIRROR to the folder of upstream clones}
E=$(realpath -m "${1:?usage: esp32s3-qemu-env.sh SCRATCH_DIR}")
JOBS=${UROS_QEMU_JOBS:-2}
mkdir -p "$E/bin"
cd "$E"
if [ -x bin/qemu-system-xtensa ] && bin/qemu-system-xtensa -cpu help | grep -qw esp32s3; then
  echo "UROS_ESP32S3_QEMU=$E/bin/qemu-system-xtensa  # $(bin/qemu-system-xtensa --version | head -1)"
  exit 0
fi

# 1. the build dependencies, and Debian's qemu source package of this release
missing=()
for p in libglib2.0-dev libpixman-1-dev ninja-build dpkg-dev python3-venv; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}"
fi
. /etc/os-release
SUITE=${VERSION_CODENAME:?no VERSION_CODENAME in /etc/os-release}
if [ ! -d src ]; then
  A=$E/apt
  mkdir -p "$A/lists/partial" "$A/cache/archives/partial" "$A/src"
  K=/usr/share/keyrings/debian-archive-keyring.gpg
  {
    echo "deb-src [signed-by=$K] http://deb.debian.org/debian $SUITE main"
    echo "deb-src [signed-by=$K] http://deb.debian.org/debian $SUITE-updates main"
    echo "deb-src [signed-by=$K] http://deb.debian.org/debian-security $SUITE-security main"
  } > "$A/sources.list"
  O=(-o "Dir::Etc::sourcelist=$A/sources.list" -o Dir::Etc::sourceparts=- -o "Dir::State::Lists=$A/lists"
     -o "Dir::Cache=$A/cache")
  apt-get "${O[@]}" -qq update
  # apt's _apt user cannot write into a folder of root's: the download runs as root (apt warns)
  (cd "$A/src" && apt-get "${O[@]}" -qq source qemu)
  mv "$(find "$A/src" -mindepth 1 -maxdepth 1 -type d -name 'qemu-*' | head -1)" src
  rm -rf "$A/src"
fi

# 2. the ESP32-S3 core, from the overlay (the files import_core.sh reads, at the paths it reads them)
if [ ! -f src/target/xtensa/core-esp32s3.c ]; then
  rm -rf overlay xtensa-overlays
  git clone -q "$M/espressif+xtensa-overlays/repo" xtensa-overlays
  O=xtensa-overlays/xtensa_esp32s3
  mkdir -p overlay/xtensa/config overlay/gdb overlay/binutils
  cp "$O/newlib/newlib/libc/sys/xtensa/include/xtensa/config/core-isa.h" overlay/xtensa/config/
  cp "$O/gdb/gdb/xtensa-config.c" overlay/gdb/
  cp "$O/binutils/bfd/xtensa-modules.c" overlay/binutils/
  printf '#ifndef XTENSA_CORE_MATMAP_H\n#define XTENSA_CORE_MATMAP_H\n/* no MPU or MMU on the ESP32-S3 */\n#endif\n' \
    > overlay/xtensa/config/core-matmap.h
  tar -czf esp32s3-overlay.tar.gz -C overlay xtensa gdb binutils
  (cd src/target/xtensa && sh ./import_core.sh "$E/esp32s3-overlay.tar.gz" esp32s3 240000)
fi
# 3. the FPU's translators beside the core's (core-de233_fpu.c has the same line)
C=src/target/xtensa/core-esp32s3.c
grep -q 'opcode_translators' "$C" || sed -i \
  's|^\(\s*\)\.isa_internal = &xtensa_modules,|&\n\1.opcode_translators = (const XtensaOpcodeTranslators *[]){\n\1    \&xtensa_core_opcodes, \&xtensa_fpu_opcodes, NULL,\n\1},|' "$C"
grep -q 'xtensa_fpu_opcodes' "$C" || { echo "error: could not add the FPU translators to $C" >&2; exit 1; }

# 4. configure and build qemu-system-xtensa only
if [ ! -f src/build/build.ninja ]; then
  mkdir -p src/build
  opts=(--target-list=xtensa-softmmu --disable-docs --disable-werror --without-default-features --disable-tools
        --disable-fdt)
  (cd src && ./configure --help 2>/dev/null | grep -q -- '--with-git-submodules') && opts+=(--with-git-submodules=ignore)
  (cd src/build && nice ../configure "${opts[@]}" >configure.log 2>&1) \
    || { tail -20 src/build/configure.log >&2; exit 1; }
fi
nice ninja -C src/build -j "$JOBS" qemu-system-xtensa
cp src/build/qemu-system-xtensa bin/qemu-system-xtensa
bin/qemu-system-xtensa -cpu help | grep -qw esp32s3 \
  || { echo "error: bin/qemu-system-xtensa lists no esp32s3 CPU" >&2; exit 1; }
echo "UROS_ESP32S3_QEMU=$E/bin/qemu-system-xtensa  # $(bin/qemu-system-xtensa --version | head -1)"
