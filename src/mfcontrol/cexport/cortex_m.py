"""An export built for a Cortex-M and run under qemu: what the on-target tests and
``benchmarks/bench_c_on_target.py`` share.

Bare metal with Debian's ``arm-none-eabi-gcc`` and newlib's semihosting (``rdimon``: the
program's ``printf`` reaches qemu's standard output, its exit code qemu's), on
``qemu-system-arm``'s MPS2 boards. qemu has no Cortex-M0 board with the RAM the drivers
need, so code built for the M0 (ARMv6-M) runs on the Cortex-M3 of ``mps2-an385``, which
executes ARMv6-M code as an M0 does (the instructions and the software floating point are
the M0 build's; the timing is not modelled on any board).
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

#: target -> (compiler flags, qemu machine)
TARGETS = {
    "m4f": (("-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16"),
            "mps2-an386"),
    "m0": (("-mcpu=cortex-m0", "-mthumb", "-mfloat-abi=soft"), "mps2-an385"),
}
#: Debian's packages that provide the tools
PACKAGES = "gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm"
TOOLS = ("arm-none-eabi-gcc", "arm-none-eabi-size", "arm-none-eabi-nm",
         "arm-none-eabi-objdump", "qemu-system-arm")

# the vector table at address 0 (the stack in the boards' RAM) and a reset handler that
# turns the FPU on where there is one (it is off at reset), then newlib's start-up
_VECTORS = r"""
extern void _start(void);
static void reset(void)
{
#if defined(__ARM_FP)
    *(volatile unsigned long *)0xE000ED88UL |= 0xFUL << 20; /* CPACR: CP10, CP11 on */
    __asm volatile ("dsb\n\tisb");
#endif
    _start();
}
__attribute__((section(".isr_vector"), used))
const void *const vectors[2] = { (const void *)0x20080000, (const void *)reset };
"""


def missing_tools() -> list[str]:
    """The tools of :data:`TOOLS` not on the PATH."""
    return [tool for tool in TOOLS if shutil.which(tool) is None]


def build(folder: Path, target: str, objects: list[str], main: str) -> Path:
    """Link ``main`` (C source text) with ``objects`` (files in ``folder``, compiled for
    ``target`` by the caller) into ``folder/drive.elf``."""
    flags, _ = TARGETS[target]
    (folder / "vectors.c").write_text(_VECTORS)
    (folder / "main.c").write_text(main)
    elf = folder / "drive.elf"
    subprocess.run(["arm-none-eabi-gcc", *flags, "-std=c99", "-O2", "--specs=rdimon.specs",
                    "-Wl,--section-start=.isr_vector=0x0", "-I", str(folder),
                    str(folder / "vectors.c"), str(folder / "main.c"),
                    *(str(folder / o) for o in objects), "-o", str(elf), "-lc", "-lrdimon",
                    "-lm"], check=True, capture_output=True, text=True, timeout=600)
    return elf


def qemu_command(elf: Path, target: str) -> list[str]:
    """The command that runs ``elf`` on ``target``'s board (standard output: the
    program's)."""
    return ["qemu-system-arm", "-M", TARGETS[target][1], "-nographic", "-monitor", "none",
            "-semihosting-config", "enable=on,target=native", "-kernel", str(elf)]
