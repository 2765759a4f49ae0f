#!/bin/bash
# Builds, into a scratch folder, what tests/integration/test_esp32_riscv_idf.py needs on a machine without
# Espressif's riscv32-esp-elf-gcc (docs/esp32.md, "The RISC-V chips against a real ESP-IDF"):
# riscv32-esp-elf-* wrappers around Debian's riscv64-unknown-elf-gcc 12.2 and binutils 2.40, with
# Espressif's newlib 4.3 headers instead of picolibc's, and an ESP-IDF v5.3.1 tree (tests/esp-idf-tree.sh,
# the same as tests/esp32s3-compat-env.sh's). Everything comes from local clones under $UROS_MIRROR
# (<owner>+<repo>/repo); nothing it writes belongs in this repository.
#
#   UROS_MIRROR=/work/.mirror bash tests/esp32-riscv-idf-env.sh /tmp/esp-rv [rv32imc rv32imac rv32imafc]
#   then: IDF_PATH=/tmp/esp-rv/idf PATH=/tmp/esp-rv/bin:$PATH UROS_MIRROR=... \
#         [UROS_ESP_NEWLIB=/tmp/esp-rv/newlib-lib] pytest tests/integration/test_esp32_riscv_idf.py
#
# With ISAs after the folder it also builds Espressif's newlib 4.3 (libc.a) for each, with Debian's
# GCC, into DIR/newlib-lib/<isa>/libc.a and libm.a (about 10 minutes each on a loaded 2-core machine): the mirror
# lacks the blob of newlib/Makefile.in, so it is regenerated with the host's autoreconf (GCC's
# config/override.m4 pins autoconf 2.69: the pin is lifted in the scratch copy), and libc.a is made
# without the math objects newlib 4.3 copies into it (automake 1.16 puts them elsewhere; libm.a has them).
#
# What the wrappers change, and nothing else:
# - riscv32-esp-elf-gcc's defaults, -march=rv32imc_zicsr_zifencei -mabi=ilp32, go before the caller's
#   flags (Debian's riscv64 driver defaults to rv64gc/lp64d; ESP-IDF passes -march, and -mabi only for
#   the P4);
# - the P4's -march=..._xesppie (ESP-IDF >= 5.3) loses _xesppie: Espressif's PIE SIMD extension is
#   unknown to GCC 12, and plain C never uses it (only ESP-DSP's assembly does);
# - -nostdinc, then GCC's own headers before newlib's (as riscv32-esp-elf-gcc searches them: GCC's
#   stdint.h wraps newlib's with #include_next; its stdatomic.h is the one used); C++
#   headers are borrowed from libstdc++-arm-none-eabi-dev (no libstdc++ for riscv64-unknown-elf in
#   Debian: a smoke build of rosidl's type support, nothing of libstdc++ is linked);
# - -B to picolibc's library folder, where uros's prerequisite check finds a libc.a (its rv64 one: the
#   proof compiles and links with `ld -r`, no C library is linked);
# - ld gets -m elf32lriscv (the riscv64 linker's default emulation is elf64).
#
# Needs: gcc-riscv64-unknown-elf, binutils-riscv64-unknown-elf, picolibc-riscv64-unknown-elf,
# libstdc++-arm-none-eabi-dev, git; pip install 'esp-idf-kconfig>=2,<3'.
set -euo pipefail
M=${UROS_MIRROR:?set UROS_MIRROR to the folder of upstream clones}
HERE=$(dirname "$(realpath "$0")")
E=$(realpath -m "${1:?usage: esp32-riscv-idf-env.sh SCRATCH_DIR}")
mkdir -p "$E/bin"
cd "$E"

. "$HERE/esp-idf-tree.sh"
esp_newlib_headers "$M"
esp_idf_tree "$M"
# RISC-V: newlib's machine/riscv sys headers (sys/asm.h, sys/fenv.h, sys/string.h), and no _LDBL_EQ_DBL:
# long double is 128-bit on RV32 (newlib's configure defines it only where it is double, as on Xtensa)
if [ ! -f newlib/include/sys/asm.h ]; then
  git --git-dir="$M/espressif+newlib-esp32/repo" archive esp-4.3.0 newlib/libc/machine/riscv/sys | tar -x -C newlib
  cp -r newlib/newlib/libc/machine/riscv/sys/. newlib/include/sys/
  sed -i '/_LDBL_EQ_DBL/d' newlib/include/newlib.h
fi

G=$(dirname "$(riscv64-unknown-elf-gcc -print-libgcc-file-name)")
# picolibc's library folder, from its specs (-print-file-name does not look where the specs link from)
PICO=$(grep -o -m1 '/[^ ;{}:%]*/lib/%M' "$(riscv64-unknown-elf-gcc -print-file-name=picolibc.specs)" | head -1)
PICO=${PICO%/%M}
CXX=/usr/lib/arm-none-eabi/include/c++/12.2.1
for t in gcc g++; do
  extra=""
  [ $t = g++ ] && extra="-isystem $CXX -isystem $CXX/arm-none-eabi -isystem $CXX/backward"
  cat > "bin/riscv32-esp-elf-$t" <<W
#!/bin/bash
# written by uros tests/esp32-riscv-idf-env.sh: Debian's riscv64-unknown-elf-$t as riscv32-esp-elf-$t
args=()
for a in "\$@"; do
  case "\$a" in -march=*_xesppie*) a=\${a//_xesppie/} ;; esac
  args+=("\$a")
done
exec riscv64-unknown-elf-$t -march=rv32imc_zicsr_zifencei -mabi=ilp32 -B$PICO/ -nostdinc $extra \\
  -isystem $G/include -isystem $G/include-fixed -isystem $E/newlib/include "\${args[@]}"
W
  chmod +x "bin/riscv32-esp-elf-$t"
done
ln -sf riscv32-esp-elf-gcc bin/riscv32-esp-elf-cc
ln -sf riscv32-esp-elf-g++ bin/riscv32-esp-elf-c++
printf '#!/bin/sh\nexec riscv64-unknown-elf-ld -m elf32lriscv "$@"\n' > bin/riscv32-esp-elf-ld
chmod +x bin/riscv32-esp-elf-ld
for t in ar ranlib nm objcopy objdump size as readelf strip addr2line gcc-ar gcc-nm gcc-ranlib; do
  ln -sf "$(command -v riscv64-unknown-elf-$t)" "bin/riscv32-esp-elf-$t"
done
# Espressif's newlib, built for each ISA named after the folder (see above)
shift
[ $# -gt 0 ] && [ ! -f newlib-src/newlib/Makefile.in ] && {
  rm -rf newlib-src && mkdir newlib-src
  git --git-dir="$M/espressif+newlib-esp32/repo" archive esp-4.3.0 -- . ':(exclude)newlib/Makefile.in' \
    | tar -x -C newlib-src
  sed -i 's/\[_GCC_AUTOCONF_VERSION\], \[2.69\]/[_GCC_AUTOCONF_VERSION], [2.71]/' newlib-src/config/override.m4
  (cd newlib-src/newlib && autoreconf -fi -I .. -I ../config 2>/dev/null)
}
for isa in "$@"; do
  [ -f "newlib-lib/$isa/libc.a" ] && continue
  case $isa in *f*) abi=ilp32f ;; *) abi=ilp32 ;; esac
  rm -rf "newlib-build/$isa" && mkdir -p "newlib-build/$isa" "newlib-lib/$isa"
  (cd "newlib-build/$isa" && "$E/newlib-src/configure" --target=riscv32-esp-elf --disable-multilib --disable-nls \
    --enable-newlib-io-long-long --enable-newlib-io-c99-formats --enable-newlib-io-pos-args \
    --enable-newlib-retargetable-locking --disable-newlib-supplied-syscalls \
    "CC_FOR_TARGET=riscv64-unknown-elf-gcc -march=${isa}_zicsr_zifencei -mabi=$abi" \
    AR_FOR_TARGET=riscv64-unknown-elf-ar RANLIB_FOR_TARGET=riscv64-unknown-elf-ranlib \
    AS_FOR_TARGET=riscv64-unknown-elf-as NM_FOR_TARGET=riscv64-unknown-elf-nm \
    "CFLAGS_FOR_TARGET=-Os -ffunction-sections -fdata-sections" > configure.log 2>&1
    make configure-target-newlib > make.log 2>&1
    make -C riscv32-esp-elf/newlib libc.a libm.a MATHOBJS_IN_LIBC= >> make.log 2>&1)
  cp "newlib-build/$isa/riscv32-esp-elf/newlib/libm.a" "newlib-lib/$isa/libm.a"
  cp "newlib-build/$isa/riscv32-esp-elf/newlib/libc.a" "newlib-lib/$isa/libc.a"
done
echo "IDF_PATH=$E/idf PATH=$E/bin:\$PATH${1:+ UROS_ESP_NEWLIB=$E/newlib-lib}"
