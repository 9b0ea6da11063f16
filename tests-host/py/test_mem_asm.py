"""The firmware's memory routines (firmware/src/mem.s, D-ARCH-7) on an emulated Cortex-M3.

The file is assembled exactly as the firmware includes it (rustc's global_asm!, for
thumbv7m-none-eabi, into an object file), and each entry point runs in Unicorn's Cortex-M3
against a Python reference: every length 0..40 and then some long ones, every alignment of both
pointers, overlaps in both directions for memmove, guard bytes around the destination, the
callee-saved registers and the stack pointer as the AAPCS requires, and the return values; and
the two 64-bit shifts for every shift count."""

import json
import pathlib
import subprocess

import pytest
from elftools.elf.elffile import ELFFile
from elftools.elf.relocation import RelocationSection
from unicorn import UC_ARCH_ARM, UC_MODE_MCLASS, UC_MODE_THUMB, Uc
from unicorn.arm_const import (
    UC_ARM_REG_LR,
    UC_ARM_REG_PC,
    UC_ARM_REG_R0,
    UC_ARM_REG_R1,
    UC_ARM_REG_R2,
    UC_ARM_REG_R4,
    UC_ARM_REG_R5,
    UC_ARM_REG_R6,
    UC_ARM_REG_R7,
    UC_ARM_REG_R8,
    UC_ARM_REG_R9,
    UC_ARM_REG_R10,
    UC_ARM_REG_R11,
    UC_ARM_REG_SP,
    UC_CPU_ARM_CORTEX_M3,
)

ROOT = pathlib.Path(__file__).resolve().parents[2]
MEM_S = ROOT / "firmware" / "src" / "mem.s"

CODE = 0x0800_0000  # the sections, one after another
RAM = 0x2000_0000
RAM_SIZE = 0x4000
STACK_TOP = RAM + RAM_SIZE
BUF = RAM + 0x100  # the test buffer (its start is word-aligned)
BUF_SIZE = 0x1800
RETURN = 0x0900_0000  # a mapped, empty page: emulation stops when the routine returns there
CALLEE_SAVED = [
    UC_ARM_REG_R4, UC_ARM_REG_R5, UC_ARM_REG_R6, UC_ARM_REG_R7,
    UC_ARM_REG_R8, UC_ARM_REG_R9, UC_ARM_REG_R10, UC_ARM_REG_R11,
]

AEABI_ENTRIES = [
    "__aeabi_memcpy", "__aeabi_memcpy4", "__aeabi_memcpy8",
    "__aeabi_memmove", "__aeabi_memmove4", "__aeabi_memmove8",
    "__aeabi_memset", "__aeabi_memset4", "__aeabi_memset8",
    "__aeabi_memclr", "__aeabi_memclr4", "__aeabi_memclr8",
]
C_ENTRIES = ["memcpy", "memmove", "memset", "memcmp", "bcmp"]
SHIFTS = ["__aeabi_llsl", "__aeabi_llsr"]


@pytest.fixture(scope="module")
def mem(tmp_path_factory):
    """The assembled routines: {symbol: address} and the Unicorn machine they are loaded in."""
    tmp = tmp_path_factory.mktemp("mem")
    crate = tmp / "mem.rs"
    crate.write_text(f"#![no_std]\ncore::arch::global_asm!(include_str!({json.dumps(str(MEM_S))}));\n")
    obj = tmp / "mem.o"
    subprocess.run(
        ["rustc", "--edition", "2021", "--target", "thumbv7m-none-eabi", "--crate-type", "lib",
         "--emit", "obj", "-o", str(obj), str(crate)],
        check=True, cwd=ROOT,
    )
    uc = Uc(UC_ARCH_ARM, UC_MODE_THUMB | UC_MODE_MCLASS)
    uc.ctl_set_cpu_model(UC_CPU_ARM_CORTEX_M3)
    uc.mem_map(CODE, 0x1000)
    uc.mem_map(RAM, RAM_SIZE)
    uc.mem_map(RETURN, 0x1000)
    symbols = {}
    with open(obj, "rb") as f:
        elf = ELFFile(f)
        for sec in elf.iter_sections():
            # Every branch stays inside its section: nothing for a linker to patch.
            if isinstance(sec, RelocationSection):
                target = elf.get_section(sec["sh_info"]).name
                assert not target.startswith(".text.mem"), f"{sec.name}: relocations in {target}"
        base, where = CODE, {}
        for i, sec in enumerate(elf.iter_sections()):
            if sec.name.startswith(".text.mem."):
                base = (base + 3) & ~3
                where[i] = base
                uc.mem_write(base, sec.data())
                base += sec["sh_size"]
        for sym in elf.get_section_by_name(".symtab").iter_symbols():
            if sym["st_info"]["bind"] == "STB_GLOBAL" and sym["st_shndx"] in where:
                assert sym["st_info"]["type"] == "STT_FUNC", sym.name
                assert sym["st_value"] & 1, f"{sym.name} is not marked Thumb"
                symbols[sym.name] = where[sym["st_shndx"]] + (sym["st_value"] & ~1)
    return symbols, uc


def call(mem, name, *args, ram=None):
    """Runs `name(args)` with `ram` at BUF; returns (r0, the buffer after the call)."""
    r0, _, after = run(mem, name, args, ram)
    return r0, after


def run(mem, name, args, ram):
    """Runs `name(args)` with `ram` at BUF; returns (r0, r1, the buffer after the call)."""
    symbols, uc = mem
    uc.mem_write(BUF, bytes(ram))
    for reg, value in zip([UC_ARM_REG_R0, UC_ARM_REG_R1, UC_ARM_REG_R2], args):
        uc.reg_write(reg, value & 0xFFFF_FFFF)
    for k, reg in enumerate(CALLEE_SAVED):
        uc.reg_write(reg, 0x5A5A_0000 + k)
    uc.reg_write(UC_ARM_REG_SP, STACK_TOP)
    uc.reg_write(UC_ARM_REG_LR, RETURN | 1)
    uc.emu_start(symbols[name] | 1, RETURN, count=200_000)
    assert uc.reg_read(UC_ARM_REG_PC) == RETURN, f"{name} did not return"
    for k, reg in enumerate(CALLEE_SAVED):
        assert uc.reg_read(reg) == 0x5A5A_0000 + k, f"{name} changed a callee-saved register"
    assert uc.reg_read(UC_ARM_REG_SP) == STACK_TOP
    return uc.reg_read(UC_ARM_REG_R0), uc.reg_read(UC_ARM_REG_R1), bytearray(uc.mem_read(BUF, len(ram)))


def pattern(n, seed):
    return bytearray((i * 37 + seed * 11 + 1) & 0xFF for i in range(n))


LENGTHS = list(range(41)) + [63, 64, 65, 255, 1024, 1027]


def test_every_entry_point_is_defined(mem):
    symbols, _ = mem
    assert sorted(symbols) == sorted(AEABI_ENTRIES + C_ENTRIES + SHIFTS)


@pytest.mark.parametrize("name", ["memcpy", "__aeabi_memcpy", "__aeabi_memcpy4", "__aeabi_memcpy8"])
def test_memcpy(mem, name):
    for n in LENGTHS:
        for s in range(4):
            for d in range(4):
                if name.endswith(("4", "8")) and (s or d):
                    continue  # the callers promise word-aligned pointers
                ram = pattern(2 * n + 64, n + s + d)
                src, dst = s, n + 32 + d
                want = ram[:]
                want[dst:dst + n] = ram[src:src + n]
                r0, got = call(mem, name, BUF + dst, BUF + src, n, ram=ram)
                assert got == want, (name, n, s, d)
                if name == "memcpy":
                    assert r0 == BUF + dst


@pytest.mark.parametrize("name", ["memmove", "__aeabi_memmove", "__aeabi_memmove4", "__aeabi_memmove8"])
def test_memmove_overlapping_both_ways(mem, name):
    for n in list(range(25)) + [255]:
        for shift in range(-9, 10):
            ram = pattern(n + 64, n + shift)
            src = 24
            dst = src + shift
            want = ram[:]
            want[dst:dst + n] = ram[src:src + n]
            r0, got = call(mem, name, BUF + dst, BUF + src, n, ram=ram)
            assert got == want, (name, n, shift)
            if name == "memmove":
                assert r0 == BUF + dst


@pytest.mark.parametrize("name", ["memset", "__aeabi_memset", "__aeabi_memset4", "__aeabi_memset8",
                                  "__aeabi_memclr", "__aeabi_memclr4", "__aeabi_memclr8"])
def test_memset_and_memclr(mem, name):
    # Only the low byte of c counts; the rest of the register is noise.
    c = 0x0012_34A5
    for n in LENGTHS:
        for d in range(4):
            if name.endswith(("4", "8")) and d:
                continue
            ram = pattern(n + 16, n + d)
            dst = 4 + d
            want = ram[:]
            want[dst:dst + n] = bytes([0 if "memclr" in name else 0xA5]) * n
            if name == "memset":
                args = (BUF + dst, c, n)
            elif name.startswith("__aeabi_memset"):
                args = (BUF + dst, n, c)  # AEABI order: (dest, n, c)
            else:
                args = (BUF + dst, n)
            r0, got = call(mem, name, *args, ram=ram)
            assert got == want, (name, n, d)
            if name == "memset":
                assert r0 == BUF + dst


@pytest.mark.parametrize("name", ["memcmp", "bcmp"])
def test_memcmp(mem, name):
    def sign(x):
        x -= (x & 0x8000_0000) << 1  # r0 as a C int
        return (x > 0) - (x < 0)

    for n in range(20):
        for k in list(range(n)) + [None]:
            for a_byte, b_byte in [(0x10, 0x20), (0x20, 0x10), (0x7F, 0x80), (0xFF, 0x01)]:
                a = pattern(n, 3)
                b = a[:]
                if k is not None:
                    a[k], b[k] = a_byte, b_byte
                ram = a + bytes(3) + b
                r0, got = call(mem, name, BUF, BUF + n + 3, n, ram=ram)
                assert got == ram, "memcmp writes nothing"
                want = 0 if k is None else (1 if a_byte > b_byte else -1)
                if name == "memcmp":
                    assert sign(r0) == want, (n, k, a_byte, b_byte)
                else:
                    assert (r0 != 0) == (want != 0), (n, k)


@pytest.mark.parametrize("name", SHIFTS)
def test_64_bit_shifts(mem, name):
    values = [0, 1, 0xFFFF_FFFF_FFFF_FFFF, 0x8000_0000_0000_0001, 0x0123_4567_89AB_CDEF, 0xFEDC_BA98_7654_3210]
    for value in values:
        for n in range(64):
            want = (value << n if name == "__aeabi_llsl" else value >> n) & 0xFFFF_FFFF_FFFF_FFFF
            lo, hi, _ = run(mem, name, (value & 0xFFFF_FFFF, value >> 32, n), bytes(4))
            assert lo | hi << 32 == want, (name, hex(value), n)
