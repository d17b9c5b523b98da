#pragma once
// Cortex-M7 core registers (CMSIS-style overlays, ARMv7-M ARM) and the start-up steps every
// board shares. Debian ships no CMSIS headers; only the registers we touch are named and
// static_asserts pin the offsets we rely on. Board headers add their peripherals.
#include <cstddef>
#include <cstdint>
#include <cstring>

#define BV_RW volatile uint32_t
#define BV_RO const volatile uint32_t

namespace bv::cm7 {

struct ScbRegs {  // System control block, 0xE000ED00
  BV_RO CPUID;
  BV_RW ICSR;
  BV_RW VTOR;
  BV_RW AIRCR;
  BV_RW SCR;
  BV_RW CCR;  // bit4 DIV_0_TRP, bit16 DC, bit17 IC
  volatile uint8_t SHPR[12];
  BV_RW SHCSR;
  BV_RW CFSR;  // MMFSR | BFSR << 8 | UFSR << 16
  BV_RW HFSR;
  BV_RW DFSR;
  BV_RW MMFAR;
  BV_RW BFAR;
  BV_RW AFSR;
  uint32_t reserved0[18];
  BV_RW CPACR;  // 0x88
  uint32_t reserved1[113];
  BV_RW ICIALLU;  // 0x250
  uint32_t reserved2[1];
  BV_RW ICIMVAU;
  BV_RW DCIMVAC;  // 0x25C invalidate by address
  BV_RW DCISW;    // 0x260
  BV_RW DCCMVAU;
  BV_RW DCCMVAC;  // 0x268 clean by address
  BV_RW DCCSW;
  BV_RW DCCIMVAC;  // 0x270 clean+invalidate by address
  BV_RW DCCISW;
};
static_assert(offsetof(ScbRegs, CFSR) == 0x28);
static_assert(offsetof(ScbRegs, BFAR) == 0x38);
static_assert(offsetof(ScbRegs, CPACR) == 0x88);
static_assert(offsetof(ScbRegs, ICIALLU) == 0x250);
static_assert(offsetof(ScbRegs, DCIMVAC) == 0x25C);
static_assert(offsetof(ScbRegs, DCCIMVAC) == 0x270);

struct CacheIdRegs {  // 0xE000ED78: CLIDR, CTR, CCSIDR, CSSELR
  BV_RO CLIDR;
  BV_RO CTR;
  BV_RO CCSIDR;
  BV_RW CSSELR;
};

struct SysTickRegs {  // 0xE000E010
  BV_RW CSR;
  BV_RW RVR;
  BV_RW CVR;
  BV_RO CALIB;
};

struct NvicRegs {  // 0xE000E100
  BV_RW ISER[8];
  uint32_t reserved0[24];
  BV_RW ICER[8];
  uint32_t reserved1[24];
  BV_RW ISPR[8];
  uint32_t reserved2[24];
  BV_RW ICPR[8];
  uint32_t reserved3[88];
  volatile uint8_t IPR[240];
};
static_assert(offsetof(NvicRegs, IPR) == 0x300);

inline ScbRegs* const kScb = reinterpret_cast<ScbRegs*>(0xE000ED00u);
inline CacheIdRegs* const kCacheId = reinterpret_cast<CacheIdRegs*>(0xE000ED78u);
inline SysTickRegs* const kSysTick = reinterpret_cast<SysTickRegs*>(0xE000E010u);
inline NvicRegs* const kNvic = reinterpret_cast<NvicRegs*>(0xE000E100u);

}  // namespace bv::cm7

// Symbols of the board linker scripts.
extern "C" {
extern uint32_t __stack_top;
extern uint32_t __data_load;
extern uint32_t __data_start;
extern uint32_t __data_end;
extern uint32_t __bss_start;
extern uint32_t __bss_end;
extern void (*__init_array_start[])();
extern void (*__init_array_end[])();
}

namespace bv::cm7 {

/// First thing after reset: FPU access (before any FP instruction), separate MemManage /
/// BusFault / UsageFault handlers, and a trap on integer divide by zero.
inline void EnableFpuAndFaultTraps() {
  kScb->CPACR = kScb->CPACR | (0xFu << 20);  // CP10/CP11 full access
  asm volatile("dsb\n isb" ::: "memory");
  kScb->SHCSR = kScb->SHCSR | (7u << 16);
  kScb->CCR = kScb->CCR | (1u << 4);
}

/// Copies .data from its load image, zeroes .bss.
inline void InitDataAndBss() {
  const size_t data_bytes = static_cast<size_t>(reinterpret_cast<uint8_t*>(&__data_end) -
                                                reinterpret_cast<uint8_t*>(&__data_start));
  std::memcpy(&__data_start, &__data_load, data_bytes);
  const size_t bss_bytes = static_cast<size_t>(reinterpret_cast<uint8_t*>(&__bss_end) -
                                               reinterpret_cast<uint8_t*>(&__bss_start));
  std::memset(&__bss_start, 0, bss_bytes);
}

// Critical sections for state shared with interrupt handlers. Host builds of board drivers
// (tests against register fakes) run the "interrupts" synchronously on one thread: no-ops.
#if defined(__arm__)
inline uint32_t IrqSave() {
  uint32_t primask;
  asm volatile("mrs %0, primask\n cpsid i" : "=r"(primask)::"memory");
  return primask;
}
inline void IrqRestore(uint32_t primask) {
  asm volatile("msr primask, %0" ::"r"(primask) : "memory");
}
#else
inline uint32_t IrqSave() { return 0; }
inline void IrqRestore(uint32_t) {}
#endif

class IrqLock {
 public:
  IrqLock() : primask_(IrqSave()) {}
  ~IrqLock() { IrqRestore(primask_); }
  IrqLock(const IrqLock&) = delete;
  IrqLock& operator=(const IrqLock&) = delete;

 private:
  uint32_t primask_;
};

// Templates so that host tests can pass a register fake (ISER is write-one-to-set).
template <typename Nvic = NvicRegs>
inline void NvicEnable(Nvic& nvic, int irq) {
  nvic.ISER[irq >> 5] = 1u << (irq & 31);
}
template <typename Nvic = NvicRegs>
inline void NvicPriority(Nvic& nvic, int irq, uint8_t prio) {
  nvic.IPR[irq] = static_cast<uint8_t>(prio << 4);
}

/// Instruction cache, then data cache (invalidated by set/way first); D-cache coherence with DMA
/// is the drivers' business (clean / invalidate by address).
inline void EnableCaches() {
  asm volatile("dsb\n isb" ::: "memory");
  kScb->ICIALLU = 0;
  asm volatile("dsb\n isb" ::: "memory");
  kScb->CCR = kScb->CCR | (1u << 17);
  kCacheId->CSSELR = 0;
  asm volatile("dsb" ::: "memory");
  const uint32_t ccsidr = kCacheId->CCSIDR;
  const uint32_t sets = ((ccsidr >> 13) & 0x7FFFu) + 1;
  const uint32_t ways = ((ccsidr >> 3) & 0x3FFu) + 1;
  for (uint32_t s = 0; s < sets; ++s) {
    for (uint32_t w = 0; w < ways; ++w) kScb->DCISW = (s << 5) | (w << 30);
  }
  asm volatile("dsb" ::: "memory");
  kScb->CCR = kScb->CCR | (1u << 16);
  asm volatile("dsb\n isb" ::: "memory");
}

/// Static constructors (after .data/.bss and anything they rely on, e.g. external RAM).
inline void RunConstructors() {
  for (auto** f = __init_array_start; f < __init_array_end; ++f) (*f)();
}

}  // namespace bv::cm7
