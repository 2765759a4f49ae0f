#!/bin/bash
# Sourced by tests/esp32s3-compat-env.sh and tests/esp32s3-real-env.sh: builds the ESP32-S3 core plugin
# (XTENSA_GNU_CONFIG) in the current folder, xtensa-dynconfig/xtensa_esp32s3.so, from local clones of
# espressif/xtensa-dynconfig and espressif/xtensa-overlays under $1 (<owner>+<repo>/repo), with
# xtensa-dynconfig's Makefile over the overlay's generated ISA tables. Nothing it writes belongs here.
build_esp32s3_plugin() {
  local mirror=$1
  [ -f xtensa-dynconfig/xtensa_esp32s3.so ] && return 0
  rm -rf xtensa-dynconfig xtensa-overlays
  git clone -q "$mirror/espressif+xtensa-dynconfig/repo" xtensa-dynconfig
  git clone -q "$mirror/espressif+xtensa-overlays/repo" xtensa-overlays
  mkdir -p xtensa-dynconfig/config
  cp -r xtensa-overlays/xtensa_esp32s3 xtensa-dynconfig/config/
  (cd xtensa-dynconfig/config && sh ../scripts/fix-known-overlay-issues.sh)
  make -s -C xtensa-dynconfig CONF_DIR=config xtensa_esp32s3.so
}
