"""Cycles of a Cortex-M0 or Cortex-M4 run, from the instructions it executed.

qemu executes the instructions of an exported controller but models no timing. The cycles
come from the processors' published timings (Arm's Cortex-M0 Technical Reference Manual,
DDI 0432C, table 3-1, and Cortex-M4's, DDI 0439B, tables 3-1 and 7-1), applied to each
instruction of the trace, with whether each branch was taken read from the next address
the trace holds. Both manuals give their counts for memory with no wait states; a part
whose flash needs wait states at its clock takes more.

- **Cortex-M0**: the counts are exact for every instruction but one choice: ``MULS`` takes
  1 cycle with the fast multiplier or 32 with the small one. :data:`M0` assumes the fast
  one (STM32F0, LPC11xx, SAMD21's M0+ and most parts); :func:`cost` takes the other.
- **Cortex-M4**: some counts are ranges, so each step has a low and a high count:
  - a load or store right after another one can overlap it and take 1 cycle (low),
    otherwise 2 (high);
  - a taken branch adds a pipeline refill P of 1 (low) to 3 (high) cycles;
  - ``SDIV``/``UDIV`` take 2 (low) to 12 (high) cycles, depending on the operands;
  - an ``IT`` may fold into the instruction before it (0 cycles, low) or take 1 (high);
  - the FPU's ``VDIV``/``VSQRT`` are counted at 14 in both: they can overlap later integer
    instructions, so the low count may overstate what a board measures.

The high count is a bound on the step for memory without wait states (a control
interrupt's budget); the low count is how fast the same instructions could run.

Examples
--------
>>> lines = ["00000100 <f>:", " 100:\\tb510      \\tpush\\t{r4, lr}",
...          " 102:\\tbd10      \\tpop\\t{r4, pc}"]
>>> code = disassembly(lines)
>>> code[0x100]
Instruction(size=2, mnemonic='push', operands='{r4, lr}')
>>> cost(code[0x102], "m0", taken=True)
(5, 5)
"""

from __future__ import annotations

import os
import re
import subprocess
import tempfile
import threading
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from mfcontrol.cexport import cortex_m

#: the two processors timed: the ARMv6-M Cortex-M0 and the ARMv7E-M Cortex-M4 (with FPU)
TARGETS = ("m0", "m4f")

_CONDITIONS = ("eq", "ne", "cs", "cc", "hs", "lo", "mi", "pl", "vs", "vc", "hi", "ls",
               "ge", "lt", "gt", "le", "al")
_LOADS_STORES = {"ldr", "ldrb", "ldrh", "ldrsb", "ldrsh", "str", "strb", "strh", "ldrex",
                 "strex", "ldrt", "strt", "ldrbt", "strbt", "ldrht", "strht", "ldrsbt",
                 "ldrsht"}
_MULTIPLE = {"ldm", "ldmia", "ldmfd", "ldmdb", "stm", "stmia", "stmea", "stmdb", "stmfd",
             "push", "pop", "vpush", "vpop", "vldm", "vldmia", "vldmdb", "vstm", "vstmia",
             "vstmdb"}
_FPU_3 = {"vmla", "vmls", "vnmla", "vnmls", "vfma", "vfms", "vfnma", "vfnms"}
_LINE = re.compile(r"^\s*([0-9a-f]+):\s+((?:[0-9a-f]{4}\s?)+)\s+(\S+)\s*(.*)$")


@dataclass(frozen=True)
class Instruction:
    """One instruction of a disassembly: its size in bytes and its text."""

    size: int
    mnemonic: str
    operands: str


def disassembly(lines: Iterable[str]) -> dict[int, Instruction]:
    """The instructions of ``arm-none-eabi-objdump -d`` output, by address.

    Lines that are not an instruction (labels, data words shown as ``.word``) are skipped.
    """
    code = {}
    for line in lines:
        m = _LINE.match(line)
        if m is None or m.group(3).startswith("."):
            continue
        raw = m.group(2).split()
        code[int(m.group(1), 16)] = Instruction(
            2 * len(raw), m.group(3).lower(), m.group(4).split("@")[0].split(";")[0].strip())
    return code


def disassemble(elf: Path) -> dict[int, Instruction]:
    """The instructions of an ELF file, by address (``arm-none-eabi-objdump -d``)."""
    out = subprocess.run(["arm-none-eabi-objdump", "-d", str(elf)], check=True,
                         capture_output=True, text=True, timeout=600).stdout
    return disassembly(out.splitlines())


def _base(mnemonic: str) -> str:
    """The mnemonic without its width qualifier (``.n``, ``.w``), data type (``.f32``) or
    condition (``beq`` -> ``b``, ``addeq`` -> ``add``)."""
    name = mnemonic.split(".")[0]
    if name in ("bl", "bls", "blx", "bx", "b"):  # bls is b + ls, blx and bx are branches
        return "b" if name in ("b", "bls") else name
    if name.startswith("b") and name[1:] in _CONDITIONS:
        return "b"
    for cond in _CONDITIONS:  # an instruction in an IT block carries its condition
        stem = name[:-2]
        if name.endswith(cond) and stem and _known(stem):
            return stem
    return name


def _known(stem: str) -> bool:
    return (stem in _LOADS_STORES or stem in _MULTIPLE or stem in _FPU_3
            or stem in ("add", "adds", "sub", "subs", "mov", "movs", "mul", "muls", "cmp",
                        "cmn", "and", "ands", "orr", "orrs", "eor", "eors", "bic", "bics",
                        "mvn", "mvns", "lsl", "lsls", "lsr", "lsrs", "asr", "asrs", "rsb",
                        "rsbs", "adc", "adcs", "sbc", "sbcs", "tst", "teq", "ldrd", "strd",
                        "sdiv", "udiv", "mla", "mls", "neg", "negs", "orn", "orns", "ror",
                        "rors", "ubfx", "sbfx", "bfi", "bfc", "clz", "ssat", "usat", "sxth",
                        "sxtb", "uxth", "uxtb", "vmov", "vadd", "vsub", "vmul", "vneg",
                        "vabs", "vcmp", "vcmpe", "vcvt", "vldr", "vstr", "vdiv", "vsqrt",
                        "vmrs", "vmsr", "vnmul"))


def _registers(operands: str) -> list[str]:
    """The registers of a list such as ``{r4, r5-r7, lr}`` (ranges expanded)."""
    inside = operands[operands.index("{") + 1:operands.index("}")]
    names: list[str] = []
    for item in inside.split(","):
        item = item.strip()
        if "-" in item:
            first, last = item.split("-")
            kind = first.rstrip("0123456789")
            names += [f"{kind}{i}" for i in range(int(first[len(kind):]),
                                                  int(last[len(kind):]) + 1)]
        elif item:
            names.append(item)
    return names


def _writes_pc(ins: Instruction) -> bool:
    first = ins.operands.split(",")[0].strip()
    return first == "pc"


def cost(ins: Instruction, target: str, taken: bool, after_memory: bool = False,
         small_multiplier: bool = False) -> tuple[int, int]:
    """(low, high) cycles of one instruction on ``target`` ("m0" or "m4f").

    ``taken``: the next instruction executed is not the one that follows in memory (a
    branch taken). ``after_memory``: the instruction before was a single load or store
    (a Cortex-M4 overlaps the two). ``small_multiplier``: a Cortex-M0 whose ``MULS`` takes
    32 cycles. On the M0 the two counts are equal.

    Examples
    --------
    >>> cost(Instruction(2, "ldr", "r0, [r1, #4]"), "m4f", taken=False, after_memory=True)
    (1, 2)
    >>> cost(Instruction(2, "bne.n", "c <f+0xc>"), "m0", taken=False)
    (1, 1)
    """
    if target not in TARGETS:
        raise ValueError(f"target {target!r}: expected one of {', '.join(TARGETS)}")
    name = _base(ins.mnemonic)
    if target == "m0":
        return (_m0(name, ins, taken, small_multiplier),) * 2
    return _m4(name, ins, taken, after_memory)


def _m0(name: str, ins: Instruction, taken: bool, small_multiplier: bool) -> int:
    if name == "b":  # conditional: 1 not taken; unconditional is always taken
        return 3 if taken else 1
    if name == "bl":
        return 4
    if name in ("bx", "blx"):
        return 3
    if name in _LOADS_STORES:
        return 2
    if name in _MULTIPLE:
        regs = _registers(ins.operands)
        if "pc" in regs:  # POP {reglist, PC}: 4 + N, N the registers other than the PC
            return 4 + len(regs) - 1
        return 1 + len(regs)
    if name in ("muls", "mul"):
        return 32 if small_multiplier else 1
    if name in ("dmb", "dsb", "isb", "mrs", "msr"):
        return 4
    if name in ("wfe", "wfi"):
        return 2
    if name in ("add", "mov") and _writes_pc(ins):
        return 3
    return 1


def _m4(name: str, ins: Instruction, taken: bool,
        after_memory: bool) -> tuple[int, int]:
    refill = (1, 3)  # P
    if name in ("b", "cbz", "cbnz"):
        return (1 + refill[0], 1 + refill[1]) if taken else (1, 1)
    if name in ("bl", "bx", "blx"):
        return 1 + refill[0], 1 + refill[1]
    if name in ("tbb", "tbh"):
        return 2 + refill[0], 2 + refill[1]
    if name in _LOADS_STORES:
        if _writes_pc(ins):  # LDR PC: 2 + P
            return 2 + refill[0], 2 + refill[1]
        return (1 if after_memory else 2), 2
    if name in ("ldrd", "strd"):
        return 3, 3
    if name in _MULTIPLE:
        regs = _registers(ins.operands)
        n = 1 + sum(2 if r.startswith("d") else 1 for r in regs)  # a d register: 2 words
        return (n + refill[0], n + refill[1]) if "pc" in regs else (n, n)
    if name in ("sdiv", "udiv"):
        return 2, 12
    if name in ("vdiv", "vsqrt"):
        return 14, 14
    if name in _FPU_3:
        return 3, 3
    if name in ("vldr", "vstr"):
        return 2, 2
    if name == "vmov" and ins.operands.count(",") >= 2:  # two core registers and a pair
        return 2, 2
    if len(name) <= 5 and name.startswith("it") and set(name[2:]) <= {"t", "e"}:
        return 0, 1
    if name in ("add", "mov") and _writes_pc(ins):
        return 1 + refill[0], 1 + refill[1]
    return 1, 1


def is_memory(ins: Instruction) -> bool:
    """A single load or store: what a Cortex-M4 overlaps with the next one."""
    return _base(ins.mnemonic) in _LOADS_STORES and not _writes_pc(ins)


class StepCycles:
    """Instructions and cycles between two marker functions in a trace of addresses.

    Feed every executed instruction's address, in order, to :meth:`feed`; each entry of
    ``before`` starts a count, the next entry of ``after`` ends it. :attr:`steps` then
    holds one ``(instructions, low cycles, high cycles)`` per span, the marker functions'
    own excluded: what runs after the first instruction of ``before`` and before the first
    of ``after`` (the caller subtracts a span around an empty call to keep the step's).
    """

    def __init__(self, code: dict[int, Instruction], target: str, before: int, after: int,
                 small_multiplier: bool = False):
        if target not in TARGETS:
            raise ValueError(f"target {target!r}: expected one of {', '.join(TARGETS)}")
        self.code, self.target = code, target
        self.before, self.after = before, after
        self.small_multiplier = small_multiplier
        self.steps: list[tuple[int, int, int]] = []
        self._costs: dict[tuple[int, int, bool], tuple[int, int, bool]] = {}
        self._inside = False
        self._previous: int | None = None
        self._after_memory = False
        self._n = self._low = self._high = 0

    def feed(self, pc: int) -> None:
        """The next address the core executed."""
        previous, self._previous = self._previous, pc
        if self._inside and previous is not None and previous != self.before:
            key = (previous, pc, self._after_memory)
            known = self._costs.get(key)
            if known is None:  # an instruction's cost depends only on this key: keep it
                ins = self.code.get(previous)
                if ins is None:
                    raise ValueError(f"no instruction at {previous:#x} in the disassembly")
                known = self._costs[key] = (
                    *cost(ins, self.target, taken=pc != previous + ins.size,
                          after_memory=self._after_memory,
                          small_multiplier=self.small_multiplier), is_memory(ins))
            low, high, self._after_memory = known
            self._n += 1
            self._low += low
            self._high += high
        if pc == self.before:
            self._inside, self._after_memory = True, False
            self._n = self._low = self._high = 0
        elif pc == self.after and self._inside:
            self.steps.append((self._n, self._low, self._high))
            self._inside = False


def _symbols(elf: Path) -> dict[str, int]:
    out = subprocess.run(["arm-none-eabi-nm", str(elf)], check=True, capture_output=True,
                         text=True, timeout=600).stdout
    return {parts[2]: int(parts[0], 16) & ~1 for parts in map(str.split, out.splitlines())
            if len(parts) == 3}


def run(elf: Path, target: str, before: str = "mark_before", after: str = "mark_after",
        small_multiplier: bool = False) -> list[tuple[int, int, int]]:
    """Run ``elf`` on ``target``'s qemu board and time every span between a call of the
    function ``before`` and the next of ``after``: one ``(instructions, low cycles, high
    cycles)`` per span (see :class:`StepCycles`).

    qemu runs one instruction at a time (``-singlestep``) and logs each one's address
    (``-d exec,nochain``) into a pipe read as it runs, so a long run needs no disk.
    """
    symbols = _symbols(elf)
    counter = StepCycles(disassemble(elf), target, symbols[before], symbols[after],
                         small_multiplier)
    pc = re.compile(rb"\[[0-9a-f]+/([0-9a-f]+)/")

    def feed(trace: str) -> None:
        with open(trace, "rb") as log:
            for line in log:
                m = pc.search(line)
                if m is not None:
                    counter.feed(int(m.group(1), 16))

    with tempfile.TemporaryDirectory() as tmp:
        trace = os.path.join(tmp, "trace.fifo")
        os.mkfifo(trace)
        reader = threading.Thread(target=feed, args=(trace,))
        reader.start()
        try:
            subprocess.run([*cortex_m.qemu_command(elf, target), "-singlestep",
                            "-d", "exec,nochain", "-D", trace], check=True,
                           capture_output=True, timeout=3600)
        finally:
            if reader.is_alive():  # qemu failed before opening the pipe: unblock the reader
                with open(trace, "wb"):
                    pass
            reader.join()
    return counter.steps
