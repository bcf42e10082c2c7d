/*
 * Minimal start-up for the STM32F405 (Cortex-M4F): the vector table, and a
 * reset handler that enables the FPU (CPACR, before any floating-point
 * instruction), copies .data from flash, zeroes .bss and calls main.
 */
#include <stdint.h>

#include "semihosting.h"

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);

/* Everything after the FPU is on: plain C. */
__attribute__((noreturn, used)) static void reset_c(void) {
    const uint32_t *src = &_sidata;
    for (uint32_t *dst = &_sdata; dst < &_edata;) *dst++ = *src++;
    for (uint32_t *dst = &_sbss; dst < &_ebss;) *dst++ = 0;
    int status = main();
    semihost_exit(status);
}

/* CPACR (0xE000ED88): full access to CP10 and CP11, then barriers; written
 * in assembly so that no compiler-generated code runs before it. */
__attribute__((naked, noreturn)) void Reset_Handler(void) {
    __asm__ volatile(
        "ldr r0, =0xE000ED88\n"
        "ldr r1, [r0]\n"
        "orr r1, r1, #(0xF << 20)\n"
        "str r1, [r0]\n"
        "dsb\n"
        "isb\n"
        "b reset_c\n");
}

/* A fault or an unexpected interrupt: report and stop QEMU with status 1. */
static void Default_Handler(void) {
    semihost_write0("unexpected exception\n");
    semihost_exit(1);
}

__attribute__((section(".isr_vector"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(&_estack), /* initial stack pointer */
    Reset_Handler,
    Default_Handler, /* NMI */
    Default_Handler, /* HardFault */
    Default_Handler, /* MemManage */
    Default_Handler, /* BusFault */
    Default_Handler, /* UsageFault */
    0, 0, 0, 0,
    Default_Handler, /* SVCall */
    Default_Handler, /* DebugMonitor */
    0,
    Default_Handler, /* PendSV */
    Default_Handler, /* SysTick */
};
