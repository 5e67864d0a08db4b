"""Cycles of a Cortex-M0 or Cortex-M4 run, from the instructions it executed.

qemu executes the instructions of an exported controller but models no timing. The cycles
come from the processors' published timings (Arm's Cortex-M0 Technical Reference Manual,
DDI 0432C, table 3-1, and Cortex-M4's, DDI 0439B, tables 3-1 and 7-1), applied to each
instruction of the trace, with whether each branch was taken read from the next address
the trace holds. Both manuals give their counts for memory with no wait states; a part
whose flash needs wait states at its clock takes more.

- **Cortex-M0**: the counts are exact for every instruction but one choice: ``MULS`` takes
  1 cycle with the fast multiplier or 32 with the small one. The counts assume the fast
  one (STM32F0, LPC11xx and most parts); ``small_multiplier=True`` takes the other. (The
  Cortex-M0+ has other timings: a taken branch costs 2, not 3.)
- **Cortex-M4**: some counts are ranges, so each step has a low and a high count:
  - a load takes 1 cycle right after a load whose result is not its address (the two
    overlap), a store with an immediate offset 1, others 2 (low); 2 each, plus 1 for a
    literal load (``[pc, #]``) and 1 for an address the instruction before computed
    (high);
  - a taken branch adds a pipeline refill P of 1 (low) to 3 (high) cycles;
  - ``SDIV``/``UDIV`` take 2 (low) to 12 (high) cycles, depending on the operands;
  - an ``IT`` may fold into a 16-bit instruction before it (0 cycles, low) or take 1;
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
    condition (``beq`` -> ``b``, ``addeq`` -> ``add``, ``bxne`` -> ``bx``)."""
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
                        "vmrs", "vmsr", "vnmul", "bl", "blx", "bx", "tbb", "tbh"))


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


def _first(ins: Instruction) -> str:
    """The first operand: the register an instruction writes (most of them)."""
    return ins.operands.split(",")[0].strip()


def _writes_pc(ins: Instruction) -> bool:
    return _first(ins) == "pc"


def _address_base(ins: Instruction) -> str:
    """The base register of a load's or store's address (``[r1, #4]`` -> ``r1``)."""
    inside = ins.operands.partition("[")[2]
    return inside.split(",")[0].split("]")[0].strip()


#: what writes no register of its first operand (a stored value, a compared one, a target)
_NO_RESULT = _MULTIPLE | {"str", "strb", "strh", "strd", "cmp", "cmn", "tst", "teq", "b",
                          "bl", "bx", "blx", "cbz", "cbnz", "vstr", "vcmp", "vcmpe"}


def _check(target: str) -> None:
    if target not in TARGETS:
        raise ValueError(f"target {target!r}: expected one of {', '.join(TARGETS)}")


def cost(ins: Instruction, target: str, taken: bool, before: Instruction | None = None,
         small_multiplier: bool = False) -> tuple[int, int]:
    """(low, high) cycles of one instruction on ``target`` ("m0" or "m4f").

    ``taken``: the next instruction executed is not the one that follows in memory (a
    branch taken). ``before``: the instruction executed just before (a Cortex-M4 overlaps
    a load with the one before it, folds an ``IT`` into a 16-bit one, and stalls a load
    whose address the one before computed). ``small_multiplier``: a Cortex-M0 whose
    ``MULS`` takes 32 cycles. On the M0 the two counts are equal.

    Examples
    --------
    >>> load = Instruction(2, "ldr", "r0, [r1, #4]")
    >>> cost(load, "m4f", taken=False, before=Instruction(2, "ldr", "r2, [r3, #0]"))
    (1, 2)
    >>> cost(Instruction(2, "bne.n", "c <f+0xc>"), "m0", taken=False)
    (1, 1)
    """
    _check(target)
    name = _base(ins.mnemonic)
    if target == "m0":
        return (_m0(name, ins, taken, small_multiplier),) * 2
    return _m4(name, ins, taken, before)


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
        before: Instruction | None) -> tuple[int, int]:
    P = (1, 3)  # the pipeline's refill after a branch taken
    if name in ("b", "cbz", "cbnz", "bl", "bx", "blx"):
        # B<cond>, CBZ: 1 not taken; the others only when their condition failed
        return (1 + P[0], 1 + P[1]) if taken else (1, 1)
    if name in ("tbb", "tbh"):  # 2 + P in table 3-1; "at least six" in section 3.3.2
        return (2 + P[0], 6) if taken else (2, 2)
    if name in _LOADS_STORES:
        if _writes_pc(ins):  # LDR PC: 2 + P (a failed condition: a load)
            return (2 + P[0], 2 + P[1]) if taken else (2, 2)
        previous = _base(before.mnemonic) if before is not None else ""
        # low: a load right after a load overlaps it (table 3-1's note: neighbouring
        # loads pipeline; nothing after a store does, nor a load whose address the one
        # before loaded), and a store with an immediate offset always takes one cycle
        # (its data phase overlaps the next instruction)
        store_imm = name.startswith("str") and "#" in ins.operands and "[pc" not in ins.operands
        after_load = (before is not None and previous.startswith("ldr")
                      and previous in _LOADS_STORES
                      and _first(before) != _address_base(ins))  # not a pointer chased
        low = 1 if store_imm or after_load else 2
        # high: a literal load "might add a cycle"; an address the instruction before
        # computed stalls one
        high = 2 + ("[pc" in ins.operands)
        if (before is not None and previous not in _NO_RESULT
                and _first(before) == _address_base(ins)):
            high += 1
        return low, high
    if name in ("ldrd", "strd"):
        return 3, 3
    if name in _MULTIPLE:
        regs = _registers(ins.operands)
        n = 1 + sum(2 if r.startswith("d") else 1 for r in regs)  # a d register: 2 words
        return (n + P[0], n + P[1]) if "pc" in regs and taken else (n, n)
    if name in ("sdiv", "udiv"):
        return 2, 12
    if name in ("vdiv", "vsqrt"):
        return 14, 14
    if name in _FPU_3:
        return 3, 3
    if name in ("vldr", "vstr"):  # single 2, double 3
        return (3, 3) if _first(ins).startswith("d") else (2, 2)
    if name == "vmov" and ins.operands.count(",") >= 2:  # two core registers and a pair
        return 2, 2
    if len(name) <= 5 and name.startswith("it") and set(name[2:]) <= {"t", "e"}:
        # folded into a 16-bit instruction before it, else one cycle
        return (0 if before is not None and before.size == 2 else 1), 1
    if name in ("mrs", "msr", "cpsid", "cpsie"):
        return 1, 2
    if name in ("dmb", "dsb", "isb"):  # 1 + B (ISB: 1 + P), B taken as at most 3
        return 2, 4
    if name in ("add", "mov") and _writes_pc(ins):
        return 1 + P[0], 1 + P[1]
    return 1, 1


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
        _check(target)
        self.code, self.target = code, target
        self.before, self.after = before, after
        self.small_multiplier = small_multiplier
        self.steps: list[tuple[int, int, int]] = []
        self._costs: dict[tuple[int | None, int, int], tuple[int, int]] = {}
        self._inside = False
        self._previous: int | None = None
        self._before: int | None = None  # the instruction before the previous one
        self._n = self._low = self._high = 0

    def feed(self, pc: int) -> None:
        """The next address the core executed."""
        previous, self._previous = self._previous, pc
        before, self._before = self._before, previous
        if self._inside and previous is not None and previous != self.before:
            key = (before, previous, pc)
            known = self._costs.get(key)
            if known is None:  # an instruction's cost depends only on this key: keep it
                ins = self.code.get(previous)
                if ins is None:
                    raise ValueError(f"no instruction at {previous:#x} in the disassembly")
                known = self._costs[key] = cost(
                    ins, self.target, taken=pc != previous + ins.size,
                    before=None if before is None else self.code.get(before),
                    small_multiplier=self.small_multiplier)
            self._n += 1
            self._low += known[0]
            self._high += known[1]
        if pc == self.before:
            self._inside = True
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
    failed: list[BaseException] = []

    def feed(trace: str) -> None:
        with open(trace, "rb") as log:
            for line in log:  # read to the end whatever happens: qemu must not block
                m = pc.search(line)
                if m is None or failed:
                    continue
                try:
                    counter.feed(int(m.group(1), 16))
                except BaseException as error:  # raised again below, after qemu
                    failed.append(error)

    with tempfile.TemporaryDirectory() as tmp:
        trace = os.path.join(tmp, "trace.fifo")
        os.mkfifo(trace)
        reader = threading.Thread(target=feed, args=(trace,))
        reader.start()
        try:
            done = subprocess.run([*cortex_m.qemu_command(elf, target), "-singlestep",
                                   "-d", "exec,nochain", "-D", trace], capture_output=True,
                                  text=True, timeout=3600)
        finally:
            try:  # qemu never opened the pipe (it failed first): let the reader's open end
                os.close(os.open(trace, os.O_WRONLY | os.O_NONBLOCK))
            except OSError:  # ENXIO: the reader is gone already
                pass
            reader.join()
    if failed:
        raise failed[0]
    if done.returncode != 0:
        raise RuntimeError(f"qemu exited with {done.returncode} running {elf}: "
                           f"{done.stderr.strip()[-2000:]}")
    return counter.steps
