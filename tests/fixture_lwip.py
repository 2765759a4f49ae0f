"""lwIP fixtures the network tests share (tests/integration/test_ip_stack.py and the unit tests):
a stand-in lwIP tree in lwIP's layout (a line or two per header, the test's own text, not lwIP's
code), and an application's config folder with lwipopts.h and arch/cc.h."""

from __future__ import annotations

from pathlib import Path


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")


def make_standin_lwip(root: Path) -> Path:
    """``root`` in lwIP's layout with the headers the client's socket code includes: lwip/sockets.h
    (which, as the real one, includes lwipopts.h through lwip/opt.h and arch/cc.h through
    lwip/arch.h), compat/posix/sys/socket.h over it, and the FreeRTOS port's arch/sys_arch.h."""
    _write(root / "src" / "include" / "lwip" / "opt.h", '#include "lwipopts.h"\n')
    _write(root / "src" / "include" / "lwip" / "arch.h", '#include "arch/cc.h"\n')
    _write(
        root / "src" / "include" / "lwip" / "sockets.h",
        '#ifndef FX_LWIP_SOCKETS_H\n#define FX_LWIP_SOCKETS_H\n#include "lwip/opt.h"\n#include "lwip/arch.h"\n'
        '#include "arch/sys_arch.h"\n#define FX_LWIP_SOCKETS 1\n#endif\n',
    )
    _write(root / "src" / "include" / "compat" / "posix" / "sys" / "socket.h", '#include "lwip/sockets.h"\n')
    _write(
        root / "contrib" / "ports" / "freertos" / "include" / "arch" / "sys_arch.h", "#define FX_SYS_ARCH 1\n"
    )
    return root


def write_lwip_config(folder: Path, mem_size: int = 1600) -> Path:
    """``folder``/lwipopts.h (MEM_SIZE ``mem_size``: the tests change it) and arch/cc.h."""
    _write(folder / "lwipopts.h", f"#define NO_SYS 0\n#define MEM_SIZE {mem_size}\n")
    _write(folder / "arch" / "cc.h", "#define FX_CC_H 1\n")
    return folder


def make_standin_freertos_tcp(root: Path) -> Path:
    """``root`` in FreeRTOS+TCP's layout with the headers the client's FreeRTOS_Plus_TCP code includes."""
    _write(root / "source" / "include" / "FreeRTOS_Sockets.h", '#include "FreeRTOSIPConfig.h"\n')
    _write(root / "source" / "include" / "FreeRTOS_IP.h", '#include "FreeRTOS_Sockets.h"\n')
    _write(root / "source" / "portable" / "Compiler" / "GCC" / "pack_struct_start.h", "\n")
    return root


def write_tcp_config(folder: Path, mtu: int = 1500) -> Path:
    """``folder``/FreeRTOSIPConfig.h (ipconfigNETWORK_MTU ``mtu``)."""
    _write(
        folder / "FreeRTOSIPConfig.h", f"#define FREERTOS_IP_CONFIG_H\n#define ipconfigNETWORK_MTU {mtu}\n"
    )
    return folder
