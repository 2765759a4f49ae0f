#!/bin/bash
# Builds picolibc for windowed ESP32-S3 code with the S3 compiler of tests/esp32s3-real-env.sh, for the
# bare-metal ESP32-S3 probe (toolchains/esp32s3-baremetal.yaml, docs/esp32.md "An ESP32-S3 core in QEMU").
# Debian's picolibc-xtensa-lx106-elf (and Debian 13's lx106 libgcc.a) are call0 builds: windowed code that
# calls into them corrupts its register window. Here:
#   1. Debian's picolibc source (the orig tarball of the Debian 13 package, fetched with `apt-get source
#      --download-only` through a private apt configuration in COMPILER_DIR/picolibc-apt);
#   2. the S3 core's core-isa.h in place of picolibc's (the lx106's: its assembly would be call0), meson with COMPILER_DIR/bin/xtensa-esp32s3-elf-gcc (-mlongcalls; windowed, the S3 core's default),
#      no multilib, no tests, no crt0 (the probe brings its start-up), errno a plain variable (no TLS:
#      nothing sets THREADPTR on bare metal), installed into COMPILER_DIR/picolibc;
#   3. its specs as COMPILER_DIR/picolibc/picolibc-esp32s3.specs with libgcc left out of the link (`*lib:
#      -lc` only, `*libgcc:` -lc: the call0 libgcc.a must not fill in what the firmware lacks; the
#      probe's board brings its windowed helpers), and -B COMPILER_DIR/picolibc/ in the gcc/g++ wrappers so that
#      --specs=picolibc-esp32s3.specs (the profile's) is found by name.
# Nothing is installed system-wide; nothing it writes belongs in this repository.
#
#   UROS_MIRROR=/work/.mirror bash tests/esp32s3-real-env.sh /tmp/esp-real
#   bash tests/esp32s3-picolibc-env.sh /tmp/esp-real
set -euo pipefail
E=$(realpath "${1:?usage: esp32s3-picolibc-env.sh COMPILER_DIR (the folder of tests/esp32s3-real-env.sh)}")
SUITE=${UROS_DEBIAN13_SUITE:-trixie}
GCC=$E/bin/xtensa-esp32s3-elf-gcc
[ -x "$GCC" ] || { echo "error: $GCC not found: run tests/esp32s3-real-env.sh $E first" >&2; exit 1; }
P=$E/picolibc
cd "$E"

ISA=$E/xtensa-overlays/xtensa_esp32s3/newlib/newlib/libc/sys/xtensa/include/xtensa/config/core-isa.h
[ -f "$ISA" ] || { echo "error: $ISA not found (tests/esp32s3-real-env.sh clones xtensa-overlays there)" >&2; exit 1; }
if ! cmp -s "$ISA" "$P/include/machine/core-isa.h" 2>/dev/null || [ ! -f "$P/lib/libc.a" ]; then
  # 1. the source
  if [ ! -d picolibc-src ]; then
    A=$E/picolibc-apt
    mkdir -p "$A/lists/partial" "$A/cache/archives/partial" "$A/src"
    echo "deb-src [signed-by=/usr/share/keyrings/debian-archive-keyring.gpg] http://deb.debian.org/debian $SUITE main" \
      > "$A/sources.list"
    O=(-o "Dir::Etc::sourcelist=$A/sources.list" -o Dir::Etc::sourceparts=- -o "Dir::State::Lists=$A/lists"
       -o "Dir::Cache=$A/cache")
    apt-get "${O[@]}" -qq update
    # only the upstream tarball is needed (it is what Debian builds from; the .dsc may be missing on a mirror)
    (cd "$A/src" && apt-get "${O[@]}" -qq source --download-only picolibc || true)
    tarball=$(ls "$A"/src/picolibc_*.orig.tar.* 2>/dev/null | head -1)
    [ -n "$tarball" ] || { echo "error: no picolibc source tarball came from Debian $SUITE" >&2; exit 1; }
    rm -rf picolibc-src.tmp && mkdir picolibc-src.tmp
    tar -xf "$tarball" -C picolibc-src.tmp --strip-components=1
    mv picolibc-src.tmp picolibc-src
  fi
  # 2. the build. picolibc's machine/core-isa.h is the lx106's (XCHAL_HAVE_WINDOWED 0): its assembly
  # (memcpy, memset, strcmp, strcpy, strlen, strncpy, setjmp) would be call0 code (ret.n, no entry)
  # whatever the compiler's ABI; the S3 core's own core-isa.h makes it windowed (entry/retw)
  cp "$ISA" picolibc-src/newlib/libc/machine/xtensa/machine/core-isa.h
  cat > picolibc-cross.txt <<EOF
[binaries]
c = ['$E/bin/xtensa-esp32s3-elf-gcc']
ar = '$E/bin/xtensa-esp32s3-elf-ar'
as = '$E/bin/xtensa-esp32s3-elf-as'
nm = '$E/bin/xtensa-esp32s3-elf-nm'
strip = '$E/bin/xtensa-esp32s3-elf-strip'

[host_machine]
system = 'none'
cpu_family = 'xtensa'
cpu = 'esp32s3'
endian = 'little'

[properties]
c_args = ['-mlongcalls']
skip_sanity_check = true
EOF
  rm -rf picolibc-build
  nice meson setup picolibc-build picolibc-src --cross-file picolibc-cross.txt --prefix="$P" \
    -Dincludedir=include -Dlibdir=lib -Dspecsdir="$P" --buildtype=minsize \
    -Dmultilib=false -Dtests=false -Dpicocrt=false -Dsemihost=false -Dthread-local-storage=false \
    -Dtls-model=local-exec >picolibc-setup.log 2>&1 || { tail -30 picolibc-setup.log >&2; exit 1; }
  nice ninja -C picolibc-build -j "${UROS_PICOLIBC_JOBS:-2}" install >picolibc-build.log 2>&1 \
    || { grep -m5 -B5 'error' picolibc-build.log >&2; exit 1; }
fi

# picolibc 1.8.10's sys/_types.h declares __errno_t/__rsize_t only when the first header included saw
# __STDC_WANT_LIB_EXT1__=1; rcutils sets it later (error_handling.h), and string.h's `typedef __errno_t
# errno_t` then fails ("unknown type name '__errno_t'"): declare them always (reserved names)
T=$P/include/sys/_types.h
if ! grep -q 'uros: always' "$T"; then
  python3 - "$T" <<'PY'
import sys
path = sys.argv[1]
text = open(path, encoding="utf-8").read()
old = "#if __STDC_WANT_LIB_EXT1__ == 1\ntypedef size_t __rsize_t;\ntypedef int __errno_t;\n#endif\n"
if old not in text:
    sys.exit(f"error: {path}: the __errno_t declaration is not where expected")
text = text.replace(old, "")
text = text.replace("#endif\t/* _SYS__TYPES_H */", "typedef size_t __rsize_t; /* uros: always */\ntypedef int __errno_t;\n#endif\t/* _SYS__TYPES_H */")
open(path, "w", encoding="utf-8").write(text)
PY
fi

# 3. the specs, without libgcc in the link
# (GCC links libgcc twice: picolibc's *lib names it, and the driver's own sequence adds %G, the *libgcc
# spec; both go: an undefined helper is then a link error, not call0 code. A spec cannot be empty:
# *libgcc becomes -lc, picolibc again)
# (first: GCC 13 calls a specs file malformed where a blank line follows the last spec's end)
{ printf '*libgcc:\n-lc\n\n'; sed -e 's/%(libgcc)//' "$P/picolibc.specs"; } > "$P/picolibc-esp32s3.specs"
for t in gcc g++; do
  w=bin/xtensa-esp32s3-elf-$t
  grep -q -- "-B$P/" "$w" || sed -i "s|\\(exec [^ ]*\\) \"\\\$@\"|\\1 -B$P/ \"\$@\"|" "$w"
  grep -q -- "-B$P/" "$w" || { echo "error: could not add -B$P/ to $w" >&2; exit 1; }
done
echo "picolibc for windowed ESP32-S3 code: $P/lib/libc.a (--specs=picolibc-esp32s3.specs)"
