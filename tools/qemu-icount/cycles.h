/*
 * An upper-bound estimate of Cortex-M4F cycles for the instructions QEMU
 * executes (icount.c, model=m4), for an STM32F405/407 at 168 MHz running
 * from flash. QEMU has no clock model, so the estimate is built from the
 * executed instruction mix and the vendor's published timings:
 *
 * Instruction costs (ARM Cortex-M4 Technical Reference Manual r0p1,
 * table 3-1 "Cortex-M4 instruction set summary" and table 7-1 "FPU
 * instruction set"), taking the upper end of every range:
 *   data processing, IT, MUL, UMULL/SMULL/UMLAL/SMLAL   1
 *   MLA, MLS                                            2
 *   SDIV, UDIV                                          12 (2-12)
 *   LDR/STR (any size), VLDR/VSTR                       2 (no pipelining credit)
 *   LDRD/STRD                                           3
 *   LDM/STM/PUSH/POP, VLDM/VSTM/VPUSH/VPOP               1 + N words
 *   TBB/TBH                                             2
 *   VADD/VSUB/VMUL/VNMUL/VABS/VNEG/VCMP/VCVT/VMOV/VMRS  1 (VMOV of two core registers 2)
 *   VMLA/VMLS/VNMLA/VNMLS/VFMA/VFMS/VFNMA/VFNMS          3
 *   VDIV, VSQRT                                         14
 *   DMB/DSB/ISB                                         4 (not in the table: a guess)
 *   a taken branch (or a write of PC)                   + 3 (pipeline refill P = 1-3)
 *   an exception, entry and return                      + 12 + 10 (no tail-chaining credit):
 *     charged when a block starts at an exception handler's address
 *     (handler=, from the vector table's symbols) or follows a block
 *     that did not end in a branch; a handler entered right after a branch
 *     or straight from another handler's return (tail-chained, as the
 *     firmware's transmit interrupt pends itself under QEMU) is an entry too
 * Memory (STM32F405/407 reference manual RM0090, section 3.5 "Embedded
 * flash memory": 5 wait states at 168 MHz and 2.7-3.6 V; the ART
 * accelerator's instruction cache of 64 lines and data cache of 8 lines of
 * 128 bits):
 *   an instruction fetch from a 16-byte flash line not among the 64 most
 *   recently used ones: + 5 after a taken branch; on straight-line code the
 *   prefetch buffer has fetched it while the previous line ran, so it costs
 *   5 less the table cycles of the instructions in that line (not below 0)
 *   a data read from a flash line not among the 8 most recently used  + 5
 *   an access to a peripheral register (APB at 42/84 MHz)             + 8
 * Assumptions: both caches fully associative with LRU replacement (the
 * manual gives no organisation), so a loop larger than 1 KiB misses on
 * every line; the prefetch starts when the previous line starts, not
 * earlier; SRAM and CCM accesses have no wait states; the core
 * never waits on the bus otherwise (no DMA here). Each choice errs towards
 * more cycles, so the estimate is an upper bound for the modelled mix.
 */
#ifndef LMS_QEMU_CYCLES_H
#define LMS_QEMU_CYCLES_H

#include <ctype.h>
#include <stdlib.h>

#define M4_WAIT_STATES 5
#define M4_REFILL 3
#define M4_EXCEPTION (12 + 10)
#define M4_PERIPHERAL 8
#define M4_ICACHE_LINES 64
#define M4_DCACHE_LINES 8
#define M4_MAX_TB_LINES 16

/* Flash at 0x0800_0000 (1 MiB) and its boot alias at 0. */
static int m4_in_flash(uint64_t a)
{
    return (a >= 0x08000000u && a < 0x08100000u) || a < 0x00100000u;
}

static int m4_in_peripheral(uint64_t a)
{
    return a >= 0x40000000u && a < 0x60000000u;
}

/* A fully associative LRU cache of `n` line tags; returns 1 on a miss. */
static int m4_touch(uint64_t *tags, size_t n, uint64_t line)
{
    size_t i = 0;
    while (i < n && tags[i] != line) {
        i++;
    }
    int miss = i == n;
    if (miss) {
        i = n - 1;
    }
    for (; i > 0; i--) {
        tags[i] = tags[i - 1];
    }
    tags[0] = line;
    return miss;
}

static uint64_t m4_icache[M4_ICACHE_LINES], m4_dcache[M4_DCACHE_LINES];
static uint64_t m4_taken, m4_exceptions, m4_imiss, m4_istall, m4_dmiss, m4_periph;

struct m4_tb {
    uint64_t start, end; /* guest addresses [start, end) */
    uint64_t base;       /* the instructions' table costs */
    int ends_in_branch;  /* the last instruction may change the flow */
    size_t n_lines;
    uint64_t lines[M4_MAX_TB_LINES]; /* flash lines fetched, in order */
    uint64_t line_cost[M4_MAX_TB_LINES]; /* table cycles of the instructions starting in each */
};

static const struct m4_tb *m4_prev;
static uint64_t *m4_cycles;

/* Exception handlers' first instructions (thumb bit clear). */
#define M4_MAX_HANDLERS 16
static uint64_t m4_handlers[M4_MAX_HANDLERS];
static size_t m4_n_handlers;

static int m4_is_handler(uint64_t a)
{
    for (size_t i = 0; i < m4_n_handlers; i++) {
        if (m4_handlers[i] == a) {
            return 1;
        }
    }
    return 0;
}

/* Registers (words) in the first {...} list of an operand string. */
static uint64_t m4_list_words(const char *ops)
{
    const char *p = strchr(ops, '{');
    uint64_t words = 0;
    if (!p) {
        return 1;
    }
    for (p++; *p && *p != '}'; p++) {
        if ((*p == 'r' || *p == 's' || *p == 'l' || *p == 'p' || *p == 'd') && (p[-1] == '{' || p[-1] == ' ')) {
            words += *p == 'd' ? 2 : 1;
        }
    }
    return words ? words : 1;
}

static int m4_is(const char *m, const char *name)
{
    return strcmp(m, name) == 0;
}

static int m4_starts(const char *m, const char *prefix)
{
    return strncmp(m, prefix, strlen(prefix)) == 0;
}

/* A branch stem: b, bl, blx, bx, or b + condition. */
static int m4_is_branch(const char *m)
{
    static const char *const conds[] = {"eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs",
                                        "vc", "hi", "ls", "ge", "lt", "gt", "le", "al"};
    if (m4_is(m, "b") || m4_is(m, "bl") || m4_is(m, "blx") || m4_is(m, "bx") || m4_is(m, "cbz") ||
        m4_is(m, "cbnz") || m4_is(m, "tbb") || m4_is(m, "tbh")) {
        return 1;
    }
    if (m[0] == 'b' && strlen(m) == 3) {
        for (size_t i = 0; i < sizeof conds / sizeof conds[0]; i++) {
            if (strcmp(m + 1, conds[i]) == 0) {
                return 1;
            }
        }
    }
    return 0;
}

/* Table cost of one instruction from its disassembly; *flow is set when it
 * may change the flow (a branch, or a load or move into PC). */
static uint64_t m4_cost(const char *disas, int *flow)
{
    char m[32];
    size_t k = 0;
    while (disas[k] && !isspace((unsigned char)disas[k]) && k + 1 < sizeof m) {
        m[k] = disas[k];
        k++;
    }
    m[k] = 0;
    const char *ops = disas + k;
    char *dot = strchr(m, '.');
    int vfp = m[0] == 'v';
    if (dot && !vfp) {
        *dot = 0; /* .w / .n width suffixes */
    }
    int writes_pc = strstr(ops, "pc}") != NULL || strncmp(ops, " pc,", 4) == 0;
    *flow = m4_is_branch(m) || writes_pc;
    if (vfp) {
        if (m4_starts(m, "vdiv") || m4_starts(m, "vsqrt")) return 14;
        if (m4_starts(m, "vmla") || m4_starts(m, "vmls") || m4_starts(m, "vnmla") || m4_starts(m, "vnmls") ||
            m4_starts(m, "vfma") || m4_starts(m, "vfms") || m4_starts(m, "vfnma") || m4_starts(m, "vfnms"))
            return 3;
        if (m4_starts(m, "vldr") || m4_starts(m, "vstr")) return 2;
        if (m4_starts(m, "vldm") || m4_starts(m, "vstm") || m4_starts(m, "vpush") || m4_starts(m, "vpop"))
            return 1 + m4_list_words(ops);
        if (m4_starts(m, "vmov")) {
            int commas = 0;
            for (const char *p = ops; *p; p++) commas += *p == ',';
            return commas >= 2 ? 2 : 1;
        }
        return 1;
    }
    if (m4_is(m, "sdiv") || m4_is(m, "udiv")) return 12;
    if (m4_is(m, "mla") || m4_is(m, "mls")) return 2;
    if (m4_starts(m, "ldrd") || m4_starts(m, "strd")) return 3;
    if (m4_starts(m, "ldm") || m4_starts(m, "stm") || m4_is(m, "push") || m4_is(m, "pop"))
        return 1 + m4_list_words(ops);
    if (m4_starts(m, "ldr") || m4_starts(m, "str") || m4_is(m, "tbb") || m4_is(m, "tbh")) return 2;
    if (m4_is(m, "dmb") || m4_is(m, "dsb") || m4_is(m, "isb")) return 4;
    return 1;
}

static int m4_is_memory(const char *disas)
{
    return strncmp(disas, "ld", 2) == 0 || strncmp(disas, "st", 2) == 0 || strncmp(disas, "pop", 3) == 0 ||
           strncmp(disas, "push", 4) == 0 || strncmp(disas, "vld", 3) == 0 || strncmp(disas, "vst", 3) == 0 ||
           strncmp(disas, "vpop", 4) == 0 || strncmp(disas, "vpush", 5) == 0 || strncmp(disas, "tb", 2) == 0;
}

static void m4_on_mem(unsigned int vcpu, qemu_plugin_meminfo_t info, uint64_t vaddr, void *udata)
{
    (void)vcpu; (void)info; (void)udata;
    if (m4_in_peripheral(vaddr)) {
        *m4_cycles += M4_PERIPHERAL;
        m4_periph++;
    } else if (m4_in_flash(vaddr) && m4_touch(m4_dcache, M4_DCACHE_LINES, vaddr >> 4)) {
        /* A store to flash does not happen in the firmware; a read pays the wait states. */
        *m4_cycles += M4_WAIT_STATES;
        m4_dmiss++;
    }
}

static void m4_on_tb(unsigned int vcpu, void *udata)
{
    (void)vcpu;
    const struct m4_tb *tb = udata;
    /* In order: the block starts where the one before ended, or, after a
     * block that did not end in a branch, inside that block's last
     * instruction: QEMU ends a block before a Thumb-2 instruction that
     * crosses a 1 KiB page and translates it again at the start of the next
     * block, and the plugin lists it in both. */
    int in_order = m4_prev && (m4_prev->end == tb->start ||
                               (!m4_prev->ends_in_branch && tb->start < m4_prev->end && tb->start + 4 >= m4_prev->end));
    if (m4_is_handler(tb->start)) {
        *m4_cycles += M4_EXCEPTION;
        m4_exceptions++;
    } else if (m4_prev && !in_order) {
        if (m4_prev->ends_in_branch) {
            *m4_cycles += M4_REFILL;
            m4_taken++;
        } else {
            *m4_cycles += M4_EXCEPTION;
            m4_exceptions++;
        }
    }
    *m4_cycles += tb->base;
    /* Prefetch credit: the cycles of the line before, when reached in order. */
    in_order = in_order && m4_prev->n_lines > 0;
    uint64_t credit = in_order ? m4_prev->line_cost[m4_prev->n_lines - 1] : 0;
    uint64_t before = in_order ? m4_prev->lines[m4_prev->n_lines - 1] : UINT64_MAX;
    for (size_t i = 0; i < tb->n_lines; i++) {
        int next_in_line = i > 0 || tb->lines[0] == before + 1;
        if (tb->lines[i] != before && m4_touch(m4_icache, M4_ICACHE_LINES, tb->lines[i])) {
            uint64_t stall = M4_WAIT_STATES;
            if (next_in_line) {
                stall = credit >= M4_WAIT_STATES ? 0 : M4_WAIT_STATES - credit;
            }
            *m4_cycles += stall;
            m4_istall += stall;
            m4_imiss++;
        }
        before = tb->lines[i];
        credit = tb->line_cost[i];
    }
    m4_prev = tb;
}

static void m4_translate(struct qemu_plugin_tb *tb, uint64_t *counter)
{
    size_t n = qemu_plugin_tb_n_insns(tb);
    if (n == 0) {
        return;
    }
    struct m4_tb *t = calloc(1, sizeof *t); /* lives as long as QEMU may run the block */
    if (!t) {
        return;
    }
    m4_cycles = counter;
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        uint64_t pc = qemu_plugin_insn_vaddr(insn);
        uint64_t size = qemu_plugin_insn_size(insn);
        char *disas = qemu_plugin_insn_disas(insn);
        int flow = 0;
        uint64_t cost = disas ? m4_cost(disas, &flow) : 1;
        t->base += cost;
        if (disas && m4_is_memory(disas)) {
            qemu_plugin_register_vcpu_mem_cb(insn, m4_on_mem, QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_MEM_RW, NULL);
        }
        free(disas);
        if (i == 0) {
            t->start = pc;
        }
        t->end = pc + size;
        t->ends_in_branch = flow;
        for (uint64_t a = pc >> 4; a <= (pc + size - 1) >> 4; a++) {
            int seen = t->n_lines > 0 && t->lines[t->n_lines - 1] == a;
            if (m4_in_flash(pc) && !seen && t->n_lines < M4_MAX_TB_LINES) {
                t->lines[t->n_lines++] = a;
            }
        }
        if (t->n_lines > 0 && (pc >> 4) == t->lines[t->n_lines - 1]) {
            t->line_cost[t->n_lines - 1] += cost;
        } else if (t->n_lines > 1 && (pc >> 4) == t->lines[t->n_lines - 2]) {
            t->line_cost[t->n_lines - 2] += cost; /* starts in the line before, ends in the last */
        }
    }
    qemu_plugin_register_vcpu_insn_exec_cb(qemu_plugin_tb_get_insn(tb, 0), m4_on_tb, QEMU_PLUGIN_CB_NO_REGS, t);
}

static void m4_report(void)
{
    char line[240];
    snprintf(line, sizeof line,
             "icount: model m4 taken_branches=%" PRIu64 " exceptions=%" PRIu64 " icache_misses=%" PRIu64
             " fetch_stall_cycles=%" PRIu64 " flash_data_misses=%" PRIu64 " peripheral_accesses=%" PRIu64 "\n",
             m4_taken, m4_exceptions, m4_imiss, m4_istall, m4_dmiss, m4_periph);
    qemu_plugin_outs(line);
}

#endif
