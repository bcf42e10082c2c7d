/*
 * Count guest instructions executed between two marker functions, for the
 * co-processor firmware's per-scan instruction budget (issue: firmware under
 * QEMU). A TCG plugin for qemu-system-arm 7.2, written against QEMU's
 * documented plugin API (docs/devel/tcg-plugins); Debian ships neither
 * plugins nor the header, so the few declarations used are below.
 *
 * Usage:
 *   qemu-system-arm ... -plugin ./icount.so,begin=0xADDR,end=0xADDR[,skip=N]
 * where begin/end are the addresses of the firmware's `scan_begin` and
 * `scan_end` functions (nm lms-firmware | grep scan_). Every executed guest
 * instruction increments one counter (inline, exact); the instruction at
 * `begin` records the counter, the one at `end` takes the difference. At
 * exit it prints one line per measured interval and a summary (with
 * profile=1 also instructions per translation block inside the intervals,
 * with profile=2 outside them, from the first `begin` on):
 *   icount: scans=N min=.. max=.. mean=.. (after skipping the first `skip`)
 *
 * With model=m4 it also estimates Cortex-M4F cycles at 168 MHz from the flash
 * (cycles.h: the model, its sources and its assumptions; handler=0xADDR,
 * repeated, names the exception handlers whose entries it charges) and
 * prints, after
 * the instruction lines,
 *   icount: cycles scans=N min=.. max=.. mean=..      (inside the intervals)
 *   icount: window cycles=.. insns=.. intervals=.. in_intervals=..
 * where the window runs from the first `begin` to the last `end`: all the
 * work of the run between them (interrupts, telegrams, the pipeline), the
 * time asleep in WFI excluded, as QEMU executes nothing then.
 */
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- the subset of qemu-plugin.h (API version 1, QEMU 7.2) used here ---- */
typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t qemu_info_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int vcpu_index, void *userdata);
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void *userdata);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *tb, size_t idx);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *insn);
void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn *insn, qemu_plugin_vcpu_udata_cb_t cb,
                                            enum qemu_plugin_cb_flags flags, void *userdata);
void qemu_plugin_register_vcpu_insn_exec_inline(struct qemu_plugin_insn *insn, enum qemu_plugin_op op,
                                                void *ptr, uint64_t imm);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void *userdata);
void qemu_plugin_outs(const char *string);
char *qemu_plugin_insn_disas(const struct qemu_plugin_insn *insn);
size_t qemu_plugin_insn_size(const struct qemu_plugin_insn *insn);
typedef uint32_t qemu_plugin_meminfo_t;
enum qemu_plugin_mem_rw { QEMU_PLUGIN_MEM_R = 1, QEMU_PLUGIN_MEM_W, QEMU_PLUGIN_MEM_RW };
typedef void (*qemu_plugin_vcpu_mem_cb_t)(unsigned int vcpu_index, qemu_plugin_meminfo_t info, uint64_t vaddr,
                                          void *userdata);
void qemu_plugin_register_vcpu_mem_cb(struct qemu_plugin_insn *insn, qemu_plugin_vcpu_mem_cb_t cb,
                                      enum qemu_plugin_cb_flags flags, enum qemu_plugin_mem_rw rw, void *userdata);
#define QEMU_PLUGIN_EXPORT __attribute__((visibility("default")))
/* -------------------------------------------------------------------------- */

#include "cycles.h"

QEMU_PLUGIN_EXPORT int qemu_plugin_version = 1;

#define MAX_INTERVALS 100000
static uint64_t executed;            /* guest instructions so far (one vCPU) */
/* end= may be given up to MAX_ENDS times: a function called from several
 * sites returns to each of them. */
#define MAX_ENDS 8
static uint64_t begin_addr, end_addrs[MAX_ENDS];
static size_t n_ends;
static uint64_t started_at;
static int open_interval;
static uint64_t intervals[MAX_INTERVALS];
static size_t n_intervals, skip;

/* model=m4: estimated cycles, per interval and over the window. */
static int model;
static uint64_t cycles, cycles_started_at, cycle_intervals[MAX_INTERVALS];
static uint64_t window_first_cycles, window_first_insns, window_cycles, window_insns, window_open;

/* profile=1: instructions executed inside measured intervals, per
 * translation block start address (a flat profile to map with addr2line). */
#define MAX_BLOCKS 65536
static int profile;
static uint64_t block_pc[MAX_BLOCKS], block_insns[MAX_BLOCKS], block_hits[MAX_BLOCKS];
/* Hits in the open interval, kept apart until `end` confirms it. */
static uint64_t pending_hits[MAX_BLOCKS];
static size_t touched[MAX_BLOCKS], n_touched;
static size_t n_blocks;

static void on_block(unsigned int vcpu, void *udata)
{
    (void)vcpu;
    size_t slot = (size_t)(uintptr_t)udata;
    if (profile == 2) {
        /* Outside the intervals, after the first one began. */
        if (window_open && !open_interval) {
            block_hits[slot]++;
        }
    } else if (open_interval) {
        if (pending_hits[slot]++ == 0 && n_touched < MAX_BLOCKS) {
            touched[n_touched++] = slot;
        }
    }
}

/* Move (keep = 1) or drop (keep = 0) the open interval's block hits. */
static void settle_profile(int keep)
{
    for (size_t i = 0; i < n_touched; i++) {
        size_t slot = touched[i];
        if (keep) {
            block_hits[slot] += pending_hits[slot];
        }
        pending_hits[slot] = 0;
    }
    n_touched = 0;
}

static void on_begin(unsigned int vcpu, void *udata)
{
    (void)vcpu; (void)udata;
    settle_profile(0);
    started_at = executed;
    cycles_started_at = cycles;
    if (!window_open) {
        window_open = 1;
        window_first_cycles = cycles;
        window_first_insns = executed;
    }
    open_interval = 1;
}

static void on_end(unsigned int vcpu, void *udata)
{
    (void)vcpu; (void)udata;
    if (open_interval && n_intervals < MAX_INTERVALS) {
        cycle_intervals[n_intervals] = cycles - cycles_started_at;
        intervals[n_intervals++] = executed - started_at;
        window_cycles = cycles - window_first_cycles;
        window_insns = executed - window_first_insns;
    }
    settle_profile(open_interval && n_intervals > skip);
    open_interval = 0;
}

static void on_translate(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    (void)id;
    size_t n = qemu_plugin_tb_n_insns(tb);
    if (profile && n > 0 && n_blocks < MAX_BLOCKS) {
        struct qemu_plugin_insn *first = qemu_plugin_tb_get_insn(tb, 0);
        size_t slot = n_blocks++;
        block_pc[slot] = qemu_plugin_insn_vaddr(first);
        block_insns[slot] = n;
        qemu_plugin_register_vcpu_insn_exec_cb(first, on_block, QEMU_PLUGIN_CB_NO_REGS, (void *)(uintptr_t)slot);
    }
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        uint64_t pc = qemu_plugin_insn_vaddr(insn);
        /* Thumb: compare without the interworking bit. */
        if (pc == (begin_addr & ~1ull)) {
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_begin, QEMU_PLUGIN_CB_NO_REGS, NULL);
        }
        for (size_t k = 0; k < n_ends; k++) {
            if (pc == (end_addrs[k] & ~1ull)) {
                qemu_plugin_register_vcpu_insn_exec_cb(insn, on_end, QEMU_PLUGIN_CB_NO_REGS, NULL);
            }
        }
        qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &executed, 1);
    }
    if (model) {
        m4_translate(tb, &cycles);
    }
}

static void at_exit(qemu_plugin_id_t id, void *udata)
{
    (void)id; (void)udata;
    char line[160];
    uint64_t min = UINT64_MAX, max = 0, sum = 0;
    size_t used = 0;
    for (size_t i = skip; i < n_intervals; i++) {
        uint64_t v = intervals[i];
        snprintf(line, sizeof line, "icount: interval %zu = %" PRIu64 "\n", i, v);
        qemu_plugin_outs(line);
        min = v < min ? v : min;
        max = v > max ? v : max;
        sum += v;
        used++;
    }
    if (used == 0) {
        min = 0;
    }
    snprintf(line, sizeof line,
             "icount: scans=%zu min=%" PRIu64 " max=%" PRIu64 " mean=%" PRIu64 " total=%" PRIu64 "\n",
             used, min, max, used ? sum / used : 0, executed);
    qemu_plugin_outs(line);
    if (model) {
        uint64_t cmin = UINT64_MAX, cmax = 0, csum = 0, in_intervals = 0;
        for (size_t i = skip; i < n_intervals; i++) {
            uint64_t v = cycle_intervals[i];
            cmin = v < cmin ? v : cmin;
            cmax = v > cmax ? v : cmax;
            csum += v;
        }
        for (size_t i = 0; i < n_intervals; i++) {
            in_intervals += cycle_intervals[i];
        }
        snprintf(line, sizeof line, "icount: cycles scans=%zu min=%" PRIu64 " max=%" PRIu64 " mean=%" PRIu64 "\n",
                 used, used ? cmin : 0, cmax, used ? csum / used : 0);
        qemu_plugin_outs(line);
        snprintf(line, sizeof line,
                 "icount: window cycles=%" PRIu64 " insns=%" PRIu64 " intervals=%zu in_intervals=%" PRIu64 "\n",
                 window_cycles, window_insns, n_intervals, in_intervals);
        qemu_plugin_outs(line);
        m4_report();
    }
    if (profile) {
        for (size_t i = 0; i < n_blocks; i++) {
            if (block_hits[i] > 0) {
                snprintf(line, sizeof line, "icount: block 0x%08" PRIx64 " insns %" PRIu64 " hits %" PRIu64 " total %" PRIu64 "\n",
                         block_pc[i], block_insns[i], block_hits[i], block_insns[i] * block_hits[i]);
                qemu_plugin_outs(line);
            }
        }
    }
}

QEMU_PLUGIN_EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    (void)info;
    for (int i = 0; i < argc; i++) {
        if (strncmp(argv[i], "begin=", 6) == 0) {
            begin_addr = strtoull(argv[i] + 6, NULL, 0);
        } else if (strncmp(argv[i], "end=", 4) == 0) {
            if (n_ends == MAX_ENDS) {
                fprintf(stderr, "icount: at most %d end= addresses\n", MAX_ENDS);
                return -1;
            }
            end_addrs[n_ends++] = strtoull(argv[i] + 4, NULL, 0);
        } else if (strncmp(argv[i], "profile=", 8) == 0) {
            profile = atoi(argv[i] + 8);
        } else if (strncmp(argv[i], "model=", 6) == 0) {
            if (strcmp(argv[i] + 6, "m4") != 0) {
                fprintf(stderr, "icount: unknown model %s (m4)\n", argv[i] + 6);
                return -1;
            }
            model = 1;
        } else if (strncmp(argv[i], "handler=", 8) == 0) {
            if (m4_n_handlers == M4_MAX_HANDLERS) {
                fprintf(stderr, "icount: at most %d handler= addresses\n", M4_MAX_HANDLERS);
                return -1;
            }
            m4_handlers[m4_n_handlers++] = strtoull(argv[i] + 8, NULL, 0) & ~(uint64_t)1;
        } else if (strncmp(argv[i], "skip=", 5) == 0) {
            skip = (size_t)strtoull(argv[i] + 5, NULL, 0);
        } else {
            fprintf(stderr, "icount: unknown argument %s (begin=, end=, skip=, profile=, model=, handler=)\n", argv[i]);
            return -1;
        }
    }
    if (begin_addr == 0 || n_ends == 0) {
        fprintf(stderr, "icount: begin= and end= addresses are required\n");
        return -1;
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_translate);
    qemu_plugin_register_atexit_cb(id, at_exit, NULL);
    return 0;
}
