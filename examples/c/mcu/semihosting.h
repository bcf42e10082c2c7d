/* ARM semihosting (bkpt 0xAB): what the MCU example needs. */
#ifndef SEMIHOSTING_H
#define SEMIHOSTING_H

static inline int semihost_call(int op, const void *arg) {
    register int r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

/* SYS_WRITE0: a NUL-terminated string to the debugger's console. */
static inline void semihost_write0(const char *s) { semihost_call(0x04, s); }

/* SYS_EXIT: ADP_Stopped_ApplicationExit (QEMU exits with 0) or
 * ADP_Stopped_RunTimeErrorUnknown (QEMU exits with 1). */
__attribute__((noreturn)) static inline void semihost_exit(int status) {
    semihost_call(0x18, (const void *)(status == 0 ? 0x20026 : 0x20023));
    for (;;) {
    }
}
#endif
