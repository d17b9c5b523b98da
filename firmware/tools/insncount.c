// TCG plugin for QEMU 7.2 (plugin API version 1): counts the exact number of guest
// instructions executed between two marker functions and prints the statistics at exit.
//   qemu-system-arm ... -plugin ./libinsncount.so,begin=0xADDR,end=0xADDR -d plugin -D log
// The plugin API is declared in qemu_plugin_api.h (Debian's QEMU ships no header). Counts
// include the few instructions of the marker functions themselves (a constant, the same for
// every interval).
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "qemu_plugin_api.h"

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

#define MAX_INTERVALS 100000
static uint64_t g_total;  // instructions executed so far (single vCPU)
static uint64_t g_begin_addr = UINT64_MAX, g_end_addr = UINT64_MAX;
static uint64_t g_mark;
static int g_open;
static uint64_t g_intervals[MAX_INTERVALS];
static size_t g_count, g_unmatched;
static int g_verbose;

static void on_begin(unsigned int vcpu, void* ud) {
  (void)vcpu, (void)ud;
  if (g_open) ++g_unmatched;
  g_mark = g_total;
  g_open = 1;
}

static void on_end(unsigned int vcpu, void* ud) {
  (void)vcpu, (void)ud;
  if (!g_open) {
    ++g_unmatched;
    return;
  }
  g_open = 0;
  if (g_count < MAX_INTERVALS) g_intervals[g_count++] = g_total - g_mark;
}

static void on_tb(qemu_plugin_id_t id, struct qemu_plugin_tb* tb) {
  (void)id;
  const size_t n = qemu_plugin_tb_n_insns(tb);
  for (size_t i = 0; i < n; ++i) {
    struct qemu_plugin_insn* insn = qemu_plugin_tb_get_insn(tb, i);
    const uint64_t pc = qemu_plugin_insn_vaddr(insn);
    // The callback runs before this instruction's inline add: the marker's own first
    // instruction is counted in neither/both consistently.
    if (pc == g_begin_addr) {
      qemu_plugin_register_vcpu_insn_exec_cb(insn, on_begin, QEMU_PLUGIN_CB_NO_REGS, NULL);
    }
    if (pc == g_end_addr) {
      qemu_plugin_register_vcpu_insn_exec_cb(insn, on_end, QEMU_PLUGIN_CB_NO_REGS, NULL);
    }
    qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &g_total, 1);
  }
}

static void on_exit_cb(qemu_plugin_id_t id, void* ud) {
  (void)id, (void)ud;
  char line[160];
  uint64_t sum = 0, mn = UINT64_MAX, mx = 0;
  for (size_t i = 0; i < g_count; ++i) {
    sum += g_intervals[i];
    if (g_intervals[i] < mn) mn = g_intervals[i];
    if (g_intervals[i] > mx) mx = g_intervals[i];
    if (g_verbose) {
      snprintf(line, sizeof line, "insncount: interval %zu: %" PRIu64 "\n", i, g_intervals[i]);
      qemu_plugin_outs(line);
    }
  }
  if (g_count == 0) mn = 0;
  snprintf(line, sizeof line,
           "insncount: intervals=%zu mean=%" PRIu64 " min=%" PRIu64 " max=%" PRIu64
           " unmatched=%zu total=%" PRIu64 "\n",
           g_count, g_count ? sum / g_count : 0, mn, mx, g_unmatched, g_total);
  qemu_plugin_outs(line);
}

__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id,
                                                               const qemu_info_t* info, int argc,
                                                               char** argv) {
  (void)info;
  for (int i = 0; i < argc; ++i) {
    if (strncmp(argv[i], "begin=", 6) == 0)
      g_begin_addr = strtoull(argv[i] + 6, NULL, 0);
    else if (strncmp(argv[i], "end=", 4) == 0)
      g_end_addr = strtoull(argv[i] + 4, NULL, 0);
    else if (strcmp(argv[i], "verbose=1") == 0)
      g_verbose = 1;
    else {
      fprintf(stderr, "insncount: unknown argument '%s' (begin=ADDR end=ADDR [verbose=1])\n",
              argv[i]);
      return -1;
    }
  }
  if (g_begin_addr == UINT64_MAX || g_end_addr == UINT64_MAX) {
    fprintf(stderr, "insncount: begin=ADDR and end=ADDR are required\n");
    return -1;
  }
  qemu_plugin_register_vcpu_tb_trans_cb(id, on_tb);
  qemu_plugin_register_atexit_cb(id, on_exit_cb, NULL);
  return 0;
}
