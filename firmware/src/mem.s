@ Memory routines and 64-bit shifts for the Cortex-M3 (ARMv7-M, Thumb-2), small rather than
@ fast (D-ARCH-7).
@ Included by firmware/src/mem.rs; tests-host/py/test_mem_asm.py runs them in an emulator.
@
@ Every routine is a leaf that touches only r0-r3, r12 and the flags (AAPCS caller-saved), and
@ keeps no state. The C ones return what C says (memcpy, memmove, memset: the destination;
@ memcmp, bcmp: the sign of the first differing byte pair, as unsigned bytes); the AEABI ones
@ return nothing. Argument orders: memcpy/memmove(dest, src, n), memset(dest, c, n),
@ __aeabi_memset(dest, n, c), __aeabi_memclr(dest, n), memcmp/bcmp(a, b, n).

    .syntax unified
    .thumb

@ A global Thumb function entry point at this address.
    .macro mem_entry name
    .global \name
    .type \name, %function
    .thumb_func
\name:
    .endm

@ ---- memcpy(dest r0, src r1, n r2) ------------------------------------------------------------
@ Words while both pointers are word-aligned (the __aeabi_memcpy4/8 callers promise it), then
@ bytes. r0 is left untouched: memcpy returns it.
    .pushsection .text.mem.memcpy, "ax", %progbits
    .p2align 1
    mem_entry __aeabi_memcpy8
    mem_entry __aeabi_memcpy4
    mem_entry __aeabi_memcpy
    mem_entry memcpy
    mov     r12, r0
    orr.w   r3, r0, r1
    lsls    r3, r3, #30         @ Z: both addresses are multiples of 4
    bne     2f
1:  subs    r2, #4              @ C (hs): at least 4 bytes were left
    ittt    hs
    ldrhs   r3, [r1], #4
    strhs   r3, [r12], #4
    bhs     1b
    adds    r2, #4              @ 0..3 bytes left
2:  subs    r2, #1
    ittt    hs
    ldrbhs  r3, [r1], #1
    strbhs  r3, [r12], #1
    bhs     2b
    bx      lr
    .size memcpy, . - memcpy
    .size __aeabi_memcpy, . - __aeabi_memcpy
    .size __aeabi_memcpy4, . - __aeabi_memcpy4
    .size __aeabi_memcpy8, . - __aeabi_memcpy8
    .popsection

@ ---- memmove(dest r0, src r1, n r2) -----------------------------------------------------------
@ Bytes, forward when dest - src >= n as unsigned numbers (dest below src, or no overlap),
@ backward from the end otherwise.
    .pushsection .text.mem.memmove, "ax", %progbits
    .p2align 1
    mem_entry __aeabi_memmove8
    mem_entry __aeabi_memmove4
    mem_entry __aeabi_memmove
    mem_entry memmove
    subs    r3, r0, r1
    cmp     r3, r2
    bhs     2f
1:  subs    r2, #1              @ backward: bytes n-1 down to 0
    ittt    hs
    ldrbhs  r3, [r1, r2]
    strbhs  r3, [r0, r2]
    bhs     1b
    bx      lr
2:  mov     r12, r0             @ forward
3:  subs    r2, #1
    ittt    hs
    ldrbhs  r3, [r1], #1
    strbhs  r3, [r12], #1
    bhs     3b
    bx      lr
    .size memmove, . - memmove
    .size __aeabi_memmove, . - __aeabi_memmove
    .size __aeabi_memmove4, . - __aeabi_memmove4
    .size __aeabi_memmove8, . - __aeabi_memmove8
    .popsection

@ ---- memset(dest r0, c r1, n r2) --------------------------------------------------------------
@ The AEABI entry points put their arguments in memset's order and fall into it. Words while the
@ destination is word-aligned, then bytes.
    .pushsection .text.mem.memset, "ax", %progbits
    .p2align 1
    mem_entry __aeabi_memclr8
    mem_entry __aeabi_memclr4
    mem_entry __aeabi_memclr
    mov     r2, r1              @ (dest, n) -> (dest, 0, n)
    movs    r1, #0
    b       .Lmemset
    mem_entry __aeabi_memset8
    mem_entry __aeabi_memset4
    mem_entry __aeabi_memset
    mov     r3, r1              @ (dest, n, c) -> (dest, c, n)
    mov     r1, r2
    mov     r2, r3
    mem_entry memset
.Lmemset:
    mov     r12, r0
    lsls    r3, r0, #30         @ Z: dest is a multiple of 4
    bne     2f
    uxtb    r1, r1              @ c in every byte of the word
    orr.w   r1, r1, r1, lsl #8
    orr.w   r1, r1, r1, lsl #16
1:  subs    r2, #4
    itt     hs
    strhs   r1, [r12], #4
    bhs     1b
    adds    r2, #4
2:  subs    r2, #1
    itt     hs
    strbhs  r1, [r12], #1
    bhs     2b
    bx      lr
    .size memset, . - memset
    .size __aeabi_memset, . - __aeabi_memset
    .size __aeabi_memset4, . - __aeabi_memset4
    .size __aeabi_memset8, . - __aeabi_memset8
    .size __aeabi_memclr, . - __aeabi_memclr
    .size __aeabi_memclr4, . - __aeabi_memclr4
    .size __aeabi_memclr8, . - __aeabi_memclr8
    .popsection

@ ---- memcmp(a r0, b r1, n r2), bcmp ----------------------------------------------------------
@ Bytes; the difference of the first unequal pair (as unsigned bytes), 0 if there is none.
@ bcmp only promises zero / non-zero: the same code serves.
    .pushsection .text.mem.memcmp, "ax", %progbits
    .p2align 1
    mem_entry bcmp
    mem_entry memcmp
1:  subs    r2, #1
    bcc     2f
    ldrb    r3, [r0], #1
    ldrb    r12, [r1], #1
    subs    r3, r3, r12
    beq     1b
    mov     r0, r3
    bx      lr
2:  movs    r0, #0
    bx      lr
    .size memcmp, . - memcmp
    .size bcmp, . - bcmp
    .popsection

@ ---- __aeabi_llsl(value r0:r1, n r2), __aeabi_llsr -------------------------------------------
@ 64-bit shifts (low word r0, high word r1; 0 <= n < 64), returned in r0:r1. A shift by a
@ register uses its low byte, so a shift by 32 gives 0 (n = 0 needs no case of its own).
    .pushsection .text.mem.llsl, "ax", %progbits
    .p2align 1
    mem_entry __aeabi_llsl
    subs    r3, r2, #32
    bpl     1f
    rsb     r3, r2, #32         @ 32 - n
    lsls    r1, r2
    lsr.w   r3, r0, r3          @ the bits that cross from the low word
    orrs    r1, r3
    lsls    r0, r2
    bx      lr
1:  lsl.w   r1, r0, r3          @ n >= 32: high = low << (n - 32)
    movs    r0, #0
    bx      lr
    .size __aeabi_llsl, . - __aeabi_llsl
    .popsection

    .pushsection .text.mem.llsr, "ax", %progbits
    .p2align 1
    mem_entry __aeabi_llsr
    subs    r3, r2, #32
    bpl     1f
    rsb     r3, r2, #32         @ 32 - n
    lsrs    r0, r2
    lsl.w   r3, r1, r3          @ the bits that cross from the high word
    orrs    r0, r3
    lsrs    r1, r2
    bx      lr
1:  lsr.w   r0, r1, r3          @ n >= 32: low = high >> (n - 32)
    movs    r1, #0
    bx      lr
    .size __aeabi_llsr, . - __aeabi_llsr
    .popsection
