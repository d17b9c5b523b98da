// TCG plugin for QEMU 7.2 (plugin API version 1): instructions executed per guest PC between the
// first `begin` marker and the last `end` marker (start-up and exit left out), written as
// "pc count" lines for firmware/tools/pcprof_report.py to add up per function. The plugin API is
// declared in qemu_plugin_api.h (Debian's QEMU ships no header).
//   gcc -shared -fPIC -O2 -o libpcprof.so firmware/tools/pcprof.c
//   qemu-system-arm ... -plugin ./libpcprof.so,out=prof.txt,begin=0xADDR,end=0xADDR -d plugin
//   python3 firmware/tools/pcprof_report.py prof.txt ELF PAIRS
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "qemu_plugin_api.h"

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

#define SLOTS (1u << 20)
static uint64_t* g_counts;  // executed instructions per halfword address (code below 2 MB)
static const char* g_out = "pcprof.txt";
static uint64_t *g_base, *g_last;  // snapshots at the first begin and the last end marker
static uint64_t g_begin_addr = UINT64_MAX, g_end_addr = UINT64_MAX;
static int g_started, g_intervals;
static void on_begin(unsigned int vcpu, void* ud) {
  (void)vcpu, (void)ud;
  if (!g_started) memcpy(g_base, g_counts, SLOTS * sizeof *g_counts);
  g_started = 1;
}
static void on_end(unsigned int vcpu, void* ud) {
  (void)vcpu, (void)ud;
  memcpy(g_last, g_counts, SLOTS * sizeof *g_counts);
  ++g_intervals;
}

static void on_tb(qemu_plugin_id_t id, struct qemu_plugin_tb* tb) {
  (void)id;
  const size_t n = qemu_plugin_tb_n_insns(tb);
  for (size_t i = 0; i < n; ++i) {
    struct qemu_plugin_insn* insn = qemu_plugin_tb_get_insn(tb, i);
    const uint64_t pc = qemu_plugin_insn_vaddr(insn);
    if (pc == g_begin_addr)
      qemu_plugin_register_vcpu_insn_exec_cb(insn, on_begin, QEMU_PLUGIN_CB_NO_REGS, NULL);
    if (pc == g_end_addr)
      qemu_plugin_register_vcpu_insn_exec_cb(insn, on_end, QEMU_PLUGIN_CB_NO_REGS, NULL);
    if ((pc >> 1) < SLOTS)
      qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64,
                                                 &g_counts[pc >> 1], 1);
  }
}

static void on_exit_cb(qemu_plugin_id_t id, void* ud) {
  (void)id, (void)ud;
  FILE* f = fopen(g_out, "w");
  if (!f) return;
  fprintf(f, "intervals %d\n", g_intervals);
  for (uint32_t i = 0; i < SLOTS; ++i)
    if (g_last[i] > g_base[i]) fprintf(f, "%x %" PRIu64 "\n", i << 1, g_last[i] - g_base[i]);
  fclose(f);
}

__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id,
                                                               const qemu_info_t* info, int argc,
                                                               char** argv) {
  (void)info;
  for (int i = 0; i < argc; ++i)
    if (strncmp(argv[i], "out=", 4) == 0)
      g_out = argv[i] + 4;
    else if (strncmp(argv[i], "begin=", 6) == 0)
      g_begin_addr = strtoull(argv[i] + 6, NULL, 0);
    else if (strncmp(argv[i], "end=", 4) == 0)
      g_end_addr = strtoull(argv[i] + 4, NULL, 0);
  g_counts = calloc(SLOTS, sizeof *g_counts);
  g_base = calloc(SLOTS, sizeof *g_counts);
  g_last = calloc(SLOTS, sizeof *g_counts);
  qemu_plugin_register_vcpu_tb_trans_cb(id, on_tb);
  qemu_plugin_register_atexit_cb(id, on_exit_cb, NULL);
  return 0;
}
