// Fault, assert and unexpected-interrupt handlers every Cortex-M7 image shares; each ends in the
// board's OnFatal. Also the C/C++ runtime hooks that would otherwise drag in the heap.
#include "hal/cortex_m/startup.h"

#include <new>

#include "hal/cortex_m/cortex_m7.h"

namespace {

[[noreturn]] void Unreachable(const char* what) {
  bv::cm7::FatalReport r;
  r.kind = bv::cm7::FatalReport::Kind::kUnreachable;
  r.what = what;
  bv::cm7::OnFatal(r);
}

}  // namespace

// Naked so that r0 is the exception frame before the compiler pushes anything.
extern "C" __attribute__((naked)) void Fault_Handler() {
  asm volatile("mrs r0, msp\n b FaultReport");
}

extern "C" [[noreturn]] __attribute__((used)) void FaultReport(const uint32_t* frame) {
  using bv::cm7::kScb;
  bv::cm7::FatalReport r;
  asm volatile("mrs %0, ipsr" : "=r"(r.ipsr));
  r.cfsr = kScb->CFSR;
  r.hfsr = kScb->HFSR;
  r.bfar = kScb->BFAR;
  r.mmfar = kScb->MMFAR;
  r.pc = frame[6];  // stacked PC of the faulting instruction
  r.lr = frame[5];
  bv::cm7::OnFatal(r);
}

extern "C" void Default_Handler() {
  bv::cm7::FatalReport r;
  r.kind = bv::cm7::FatalReport::Kind::kUnexpectedIrq;
  asm volatile("mrs %0, ipsr" : "=r"(r.ipsr));
  bv::cm7::OnFatal(r);
}

// Newlib's version drags in stdio and malloc (and then fails the heap guard).
extern "C" [[noreturn]] void __assert_func(const char* file, int line, const char* func,
                                           const char* expr) {
  bv::cm7::FatalReport r;
  r.kind = bv::cm7::FatalReport::Kind::kAssert;
  r.file = file;
  r.line = line;
  r.func = func;
  r.what = expr;
  bv::cm7::OnFatal(r);
}

// Virtual destructors make the compiler emit deleting destructors that reference operator
// delete; nothing is ever allocated, so these are never reached. Defining them keeps libstdc++'s
// versions (and through them free()/the allocator) out of the image.
void operator delete(void*) noexcept { Unreachable("operator delete"); }
void operator delete(void*, size_t) noexcept { Unreachable("operator delete"); }
void operator delete(void*, std::align_val_t) noexcept { Unreachable("operator delete"); }
void operator delete(void*, size_t, std::align_val_t) noexcept { Unreachable("operator delete"); }

// Function-local statics with (virtual) destructors register them through atexit() because of
// -fno-use-cxa-atexit. The firmware never returns from main (it exits through semihosting or
// resets), so nothing is ever destroyed: keep newlib's atexit tables out of the image.
extern "C" int atexit(void (*)()) { return 0; }
