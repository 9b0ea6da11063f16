//! Small memory routines for the image: `memcpy`, `memmove`, `memset`, `memcmp`, `bcmp` and
//! their ARM EABI entry points (`__aeabi_memcpy`, `__aeabi_memclr8`, ...), and the 64-bit shifts
//! `__aeabi_llsl` and `__aeabi_llsr`, in Thumb-2 assembly (`mem.s`; D-ARCH-7).
//!
//! compiler-builtins defines all of them as weak symbols, tuned for speed: about 1.5 KiB of
//! unrolled loops in each image. These strong definitions replace them for about 180 bytes.
//! A word loop when both pointers are word-aligned (memcpy) or the destination is (memset), a byte
//! loop otherwise and for the tail; no unrolling. Written in assembly rather than Rust because
//! LLVM turns a copy loop in Rust back into a call to `memcpy`, which would then call itself.
//!
//! Each group is in a section of its own, so the linker keeps only what an image references.
//! `tests-host/py/test_mem_asm.py` assembles the same file for the Cortex-M3 and runs every entry
//! point in an emulator against a reference, for every length, alignment and overlap that
//! matters.

core::arch::global_asm!(include_str!("mem.s"));
