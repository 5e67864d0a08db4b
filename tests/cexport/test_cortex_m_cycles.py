"""The cycle counts of a Cortex-M run (mfcontrol.cexport.cortex_m_cycles) against sums
worked out by hand from Arm's manuals: the Cortex-M0 TRM (DDI 0432C) table 3-1, the
Cortex-M4 TRM (DDI 0439B) tables 3-1 and 7-1.

The end-to-end test runs a routine written in assembly under qemu, so the disassembly's
parsing, the taken branches read from the trace and the register lists all count.
Skipped without the tools unless MFCONTROL_REQUIRE_ARM=1 (CI installs them and sets it).
"""

from __future__ import annotations

import subprocess

import pytest

from mfcontrol.cexport import cortex_m
from mfcontrol.cexport.cortex_m_cycles import Instruction, StepCycles, cost, disassembly

from .test_on_target import _require_tools


def _ins(text: str, size: int = 2) -> Instruction:
    mnemonic, _, operands = text.partition(" ")
    return Instruction(size, mnemonic, operands.strip())


@pytest.mark.parametrize("text,taken,cycles", [
    ("movs r0, #1", False, 1),
    ("adds r0, r1, r2", False, 1),
    ("muls r1, r1, r1", False, 1),
    ("ldr r0, [r1, #4]", False, 2),
    ("str r0, [sp, #8]", False, 2),
    ("ldmia r2!, {r1}", False, 2),
    ("push {r4, r5, r6, lr}", False, 5),  # 1 + N
    ("pop {r4, r5, r6, r7}", False, 5),
    ("pop {r4, pc}", True, 5),  # 4 + N, N the low registers
    ("pop {r4-r7, pc}", True, 8),
    ("bne.n 1c <f+0x1c>", False, 1),
    ("bne.n 1c <f+0x1c>", True, 3),
    ("b.n 1a <f+0x1a>", True, 3),
    ("bls.n 30 <f+0x30>", True, 3),  # "b" + "ls", not "bl"
    ("bl 0 <__aeabi_fdiv>", True, 4),
    ("bx lr", True, 3),
    ("blx r3", True, 3),
    ("mov pc, lr", True, 3),
    ("dsb sy", False, 4),
])
def test_cortex_m0_cycles_are_table_3_1s(text, taken, cycles):
    ins = _ins(text, 4 if text.startswith(("bl ", "dsb")) else 2)
    assert cost(ins, "m0", taken=taken) == (cycles, cycles)


def test_the_m0_small_multiplier_takes_32_cycles():
    assert cost(_ins("muls r1, r1, r1"), "m0", taken=False, small_multiplier=True) == (32, 32)


_MOVS, _LOAD, _STORE = "movs r3, #1", "ldr r2, [r3, #0]", "str r2, [r3, #0]"


@pytest.mark.parametrize("text,taken,before,cycles", [
    ("add.w r1, r2, r1, lsl #2", False, None, (1, 1)),
    ("umull r0, ip, r0, r2", False, None, (1, 1)),  # the M4's single-cycle 32 x 32 -> 64
    ("mla r1, r2, r1, r3", False, None, (1, 1)),
    ("sdiv r0, r1, r2", False, None, (2, 12)),
    ("ldr r0, [r1, #4]", False, None, (2, 2)),
    ("ldr.w r0, [r1, #4]!", False, _LOAD, (1, 2)),  # may overlap the load before
    ("ldr.w r0, [r2, #4]", False, _LOAD, (2, 3)),  # not when the load gave its address
    ("ldr r0, [r1, #4]", False, _STORE, (2, 2)),  # nothing overlaps a store
    ("str r0, [r1, #4]", False, None, (1, 2)),  # a store with an immediate offset: 1
    ("str r0, [r1, r2]", False, None, (2, 2)),
    ("ldr r0, [r3, #4]", False, _MOVS, (2, 3)),  # its address just computed: a stall
    ("ldr r0, [pc, #8]", False, None, (2, 3)),  # a literal "might add a cycle"
    ("ldrd r0, r1, [r2]", False, None, (3, 3)),
    ("push {r4, r5, lr}", False, None, (4, 4)),
    ("pop {r4, pc}", True, None, (4, 6)),  # 1 + N + P
    ("popne {r4, pc}", False, None, (3, 3)),  # its condition failed: no refill
    ("bne.n c <f+0xc>", False, None, (1, 1)),
    ("bne.n c <f+0xc>", True, None, (2, 4)),  # 1 + P, P from 1 to 3
    ("cbz r0, 10 <f+0x10>", True, None, (2, 4)),
    ("bl 0 <g>", True, None, (2, 4)),
    ("bxeq lr", True, None, (2, 4)),  # a branch in an IT block
    ("bxeq lr", False, None, (1, 1)),
    ("tbb [pc, r3]", True, None, (3, 6)),
    ("ite ne", False, _MOVS, (0, 1)),  # folded into a 16-bit instruction before it
    ("ite ne", False, "add.w r1, r2, r1, lsl #2", (1, 1)),  # not into a 32-bit one
    ("movne r0, #1", False, None, (1, 1)),
    ("ldrne r0, [r1]", False, None, (2, 2)),  # a condition from an IT block
    ("mrs r0, PRIMASK", False, None, (1, 2)),
    ("vadd.f32 s0, s0, s1", False, None, (1, 1)),
    ("vfma.f32 s15, s0, s1", False, None, (3, 3)),
    ("vdiv.f32 s15, s0, s1", False, None, (14, 14)),
    ("vldr s15, [r0, #4]", False, None, (2, 2)),
    ("vldr d8, [r0, #8]", False, None, (3, 3)),
    ("vmov r0, r1, d0", False, None, (2, 2)),
    ("vmov s0, r0", False, None, (1, 1)),
    ("vpush {s16-s19}", False, None, (5, 5)),
    ("vpush {d8}", False, None, (3, 3)),
])
def test_cortex_m4_cycles_are_tables_3_1_and_7_1s(text, taken, before, cycles):
    size = 2 if before in (_MOVS, _LOAD, _STORE) else 4
    before = None if before is None else _ins(before, size)
    assert cost(_ins(text, 4), "m4f", taken=taken, before=before) == cycles


def test_a_failure_reading_the_trace_is_raised_not_lost(tmp_path, monkeypatch):
    """An address missing from the disassembly stops the count with an error (it was
    swallowed in the reader's thread, and run returned the spans before it)."""
    import mfcontrol.cexport.cortex_m_cycles as cycles

    _require_tools()
    elf = _build(tmp_path, "m0")
    code = cycles.disassemble(elf)
    routine = cycles._symbols(elf)["routine"]  # its first instruction: run in a span
    monkeypatch.setattr(cycles, "disassemble",
                        lambda _: {a: i for a, i in code.items() if a != routine})
    with pytest.raises(ValueError, match="no instruction at"):
        cycles.run(elf, "m0")


def test_an_unknown_target_is_refused():
    with pytest.raises(ValueError, match="target 'm7'"):
        cost(_ins("movs r0, #1"), "m7", taken=False)


def test_the_trace_is_read_between_the_markers():
    code = disassembly([" 10:\t4770      \tbx\tlr",  # before
                        " 20:\t4770      \tbx\tlr",  # after
                        " 30:\t2001      \tmovs\tr0, #1",
                        " 32:\td1fd      \tbne.n\t30 <f+0x30>",
                        " 34:\t6808      \tldr\tr0, [r1, #0]"])
    counter = StepCycles(code, "m0", before=0x10, after=0x20)
    for pc in (0x30, 0x10, 0x30, 0x32, 0x30, 0x32, 0x34, 0x20, 0x30):
        counter.feed(pc)
    # movs 1, bne taken 3, movs 1, bne not taken 1, ldr 2
    assert counter.steps == [(5, 8, 8)]


_ROUTINE = r"""
    .syntax unified
    .thumb
    .text
    .global routine
    .thumb_func
    .type routine, %function
routine:
    push {r4, lr}
    movs r4, #3
1:  subs r4, #1
    bne 1b
    ldr r1, [r0]
    str r1, [r0]
    muls r1, r1, r1
#if defined(__ARM_ARCH_7EM__)
    sdiv r2, r1, r1
    vmov s0, r1
    vdiv.f32 s1, s0, s0
#endif
    pop {r4, pc}

    .global empty
    .thumb_func
    .type empty, %function
empty:
    bx lr
"""

_MAIN = r"""
extern void routine(unsigned long *p);
extern void empty(unsigned long *p);
__attribute__((noinline)) void mark_before(void) { __asm volatile (""); }
__attribute__((noinline)) void mark_after(void) { __asm volatile (""); }

/* one function for both spans (noipa: not cloned per argument), so that the instructions
 * around the call are the same in both */
__attribute__((noipa)) static void span(void (*f)(unsigned long *), unsigned long *p)
{
    mark_before();
    f(p);
    mark_after();
}

int main(void)
{
    static unsigned long x = 5;
    span(empty, &x);
    span(routine, &x);
    return 0;
}
"""

#: the routine less the empty function (bx lr: M0 3, M4 1 + P), worked out by hand
EXPECTED = {
    # push {r4, lr} 3, movs 1, subs 3 x 1, bne taken 2 x 3 and not 1, ldr 2, str 2,
    # muls 1, pop {r4, pc} 4 + 1 = 24 cycles in 12 instructions
    "m0": (12 - 1, 24 - 3, 24 - 3),
    # push 3, movs 1, subs 3, bne taken 2 x (2..4) and not 1, ldr 2, str 1..2 (after the
    # load), muls 1, sdiv 2..12, vmov 1, vdiv 14, pop {r4, pc} 4..6: 37..54 in 15
    "m4f": (15 - 1, 37 - 2, 54 - 4),
}


def _build(folder, target: str):
    flags, _ = cortex_m.TARGETS[target]
    (folder / "routine.S").write_text(_ROUTINE)
    subprocess.run(["arm-none-eabi-gcc", *flags, "-c", "routine.S", "-o", "routine.o"],
                   cwd=folder, check=True, timeout=600)
    return cortex_m.build(folder, target, ["routine.o"], _MAIN)


@pytest.mark.parametrize("target", ["m0", "m4f"])
def test_a_routine_run_under_qemu_takes_the_cycles_counted_by_hand(target, tmp_path):
    from mfcontrol.cexport.cortex_m_cycles import run

    _require_tools()
    empty, routine = run(_build(tmp_path, target), target)
    assert tuple(a - b for a, b in zip(routine, empty, strict=True)) == EXPECTED[target]
