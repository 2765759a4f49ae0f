#!/bin/bash
# Builds, into a scratch folder, what tests/integration/test_esp32s3_proof.py needs on a machine without
# Espressif's compiler (docs/esp32.md, "The ESP32-S3 proof"): xtensa-esp32s3-elf-* wrappers around
# Debian's gcc-xtensa-lx106 12.2 (-mabi=windowed) and binutils 2.40 (dynconfig: XTENSA_GNU_CONFIG loads
# the ESP32-S3 core plugin, built here from espressif/xtensa-dynconfig + espressif/xtensa-overlays),
# Espressif's newlib 4.3 headers, and an ESP-IDF v5.3.1 tree. Everything comes from local clones under
# $UROS_MIRROR (<owner>+<repo>/repo); nothing it writes belongs in this repository.
#
#   UROS_MIRROR=/work/.mirror bash tests/esp32s3-compat-env.sh /tmp/esp
#   then: IDF_PATH=/tmp/esp/idf PATH=/tmp/esp/bin:$PATH UROS_MIRROR=... pytest tests/integration/test_esp32s3_proof.py
#
# Needs: gcc-xtensa-lx106, binutils-xtensa-lx106, libstdc++-arm-none-eabi-dev (C++ headers for the
# smoke build only: lx106 has no libstdc++), a host cc, make, git; pip install 'esp-idf-kconfig>=2,<3'.
set -euo pipefail
M=${UROS_MIRROR:?set UROS_MIRROR to the folder of upstream clones}
HERE=$(dirname "$(realpath "$0")")
E=$(realpath -m "${1:?usage: esp32s3-compat-env.sh SCRATCH_DIR}")
mkdir -p "$E/bin" "$E/newlib"
cd "$E"

# 1. the core plugin (tests/esp32s3-plugin.sh)
. "$HERE/esp32s3-plugin.sh"
build_esp32s3_plugin "$M"

# 2. newlib 4.3 headers (tests/esp-idf-tree.sh), with the S3 core's ISA header for <xtensa/config/core-isa.h>
. "$HERE/esp-idf-tree.sh"
esp_newlib_headers "$M"
if [ ! -f newlib/include/xtensa/config/core-isa.h ]; then
  git --git-dir="$M/espressif+newlib-esp32/repo" archive esp-4.3.0 newlib/libc/machine/xtensa/include | tar -x -C newlib
  cp -r newlib/newlib/libc/machine/xtensa/include/. newlib/include/
  cp xtensa-overlays/xtensa_esp32s3/newlib/newlib/libc/sys/xtensa/include/xtensa/config/core-isa.h \
    newlib/include/xtensa/config/core-isa.h 2>/dev/null || true
fi

# 3. the wrappers: windowed ABI, the S3 core for gas/ld, newlib instead of picolibc
# UROS_XTENSA_BIN: another xtensa-lx106-elf toolchain's bin folder, e.g. tests/esp32s3-real-env.sh's
# DIR/root/usr/bin (Debian 13's GCC 13.3, which reads the plugin: real ESP32-S3 code with these headers)
BIN=${UROS_XTENSA_BIN:-/usr/bin}
G=$(dirname "$("$BIN/xtensa-lx106-elf-gcc" -print-libgcc-file-name)")
# the libc.a of the system's lx106 C library, for uros's prerequisite check (the proof compiles only; a
# GCC unpacked elsewhere does not look in /usr): -B adds its folder to where -print-file-name looks
LIBC_B=""
if [ "$BIN" != /usr/bin ] && L=$(xtensa-lx106-elf-gcc -print-file-name=libc.a 2>/dev/null) && [ -f "$L" ]; then
  LIBC_B="-B$(dirname "$(realpath "$L")")/"
fi
CXX=/usr/lib/arm-none-eabi/include/c++/12.2.1
SO=$E/xtensa-dynconfig/xtensa_esp32s3.so
for t in gcc g++; do
  extra=""
  [ $t = g++ ] && extra="-isystem $CXX -isystem $CXX/arm-none-eabi -isystem $CXX/backward"
  cat > "bin/xtensa-esp32s3-elf-$t" <<W
#!/bin/sh
XTENSA_GNU_CONFIG=$SO exec $BIN/xtensa-lx106-elf-$t -mabi=windowed $LIBC_B -nostdinc $extra -isystem $E/newlib/include -isystem $G/include -isystem $G/include-fixed "\$@"
W
  chmod +x "bin/xtensa-esp32s3-elf-$t"
done
ln -sf xtensa-esp32s3-elf-gcc bin/xtensa-esp32s3-elf-cc
for t in ar ranlib nm objcopy objdump size ld as readelf strip addr2line; do
  printf '#!/bin/sh\nXTENSA_GNU_CONFIG=%s exec %s/xtensa-lx106-elf-%s "$@"\n' "$SO" "$BIN" $t > "bin/xtensa-esp32s3-elf-$t"
  chmod +x "bin/xtensa-esp32s3-elf-$t"
done

# 4. ESP-IDF v5.3.1 (tests/esp-idf-tree.sh)
esp_idf_tree "$M"
echo "IDF_PATH=$E/idf PATH=$E/bin:\$PATH"
