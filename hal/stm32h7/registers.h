#pragma once
// CMSIS-style register overlays for the STM32H743 peripherals this port uses (RM0433 rev 8).
// Debian ships no CMSIS/ST headers; only the registers we touch are named, the rest is padding,
// and static_asserts pin the offsets we rely on.
#include <cstddef>
#include <cstdint>

#include "hal/cortex_m/cortex_m7.h"

namespace bv::h7 {

using cm7::CacheIdRegs;
using cm7::kCacheId;
using cm7::kNvic;
using cm7::kScb;
using cm7::NvicRegs;
using cm7::ScbRegs;

static_assert(offsetof(NvicRegs, IPR) == 0x300);

struct ItmRegs {  // 0xE0000000: stimulus port 0 is the debug log (SWO), if a probe enabled it
  BV_RW PORT[32];
  uint32_t reserved0[864];
  BV_RW TER;  // 0xE00
  uint32_t reserved1[15];
  BV_RW TPR;
  uint32_t reserved2[15];
  BV_RW TCR;  // 0xE80
};
static_assert(offsetof(ItmRegs, TER) == 0xE00);
static_assert(offsetof(ItmRegs, TCR) == 0xE80);

struct RccRegs {  // 0x58024400
  BV_RW CR;       // 0x00: HSION 0, HSERDY 17, HSEON 16, PLL1ON 24, PLL1RDY 25
  BV_RW HSICFGR;
  BV_RW CRRCR;
  BV_RW CSICFGR;
  BV_RW CFGR;  // 0x10: SW 2:0, SWS 5:3
  uint32_t reserved0;
  BV_RW D1CFGR;  // 0x18: HPRE 3:0, D1PPRE 6:4, D1CPRE 11:8
  BV_RW D2CFGR;  // 0x1C: D2PPRE1 6:4, D2PPRE2 10:8
  BV_RW D3CFGR;  // 0x20: D3PPRE 6:4
  uint32_t reserved1;
  BV_RW PLLCKSELR;  // 0x28: PLLSRC 1:0, DIVM1 9:4
  BV_RW PLLCFGR;    // 0x2C
  BV_RW PLL1DIVR;   // 0x30: DIVN1 8:0, DIVP1 15:9, DIVQ1 22:16, DIVR1 30:24
  BV_RW PLL1FRACR;
  BV_RW PLL2DIVR;
  BV_RW PLL2FRACR;
  BV_RW PLL3DIVR;
  BV_RW PLL3FRACR;
  uint32_t reserved2;
  BV_RW D1CCIPR;  // 0x4C: FMCSEL 1:0
  BV_RW D2CCIP1R;
  BV_RW D2CCIP2R;  // 0x54: USART16SEL 5:3
  BV_RW D3CCIPR;
  uint32_t reserved3[29];
  BV_RW RSR;      // 0xD0 reset cause
  BV_RW AHB3ENR;  // 0xD4: FMCEN 12
  BV_RW AHB1ENR;  // 0xD8: DMA1EN 0, DMA2EN 1
  BV_RW AHB2ENR;  // 0xDC: DCMIEN 0
  BV_RW AHB4ENR;  // 0xE0: GPIOxEN x
  BV_RW APB3ENR;
  BV_RW APB1LENR;  // 0xE8: TIM2EN 0
  BV_RW APB1HENR;
  BV_RW APB2ENR;  // 0xF0: USART1EN 4
  BV_RW APB4ENR;
};
static_assert(offsetof(RccRegs, PLL1DIVR) == 0x30);
static_assert(offsetof(RccRegs, D2CCIP2R) == 0x54);
static_assert(offsetof(RccRegs, RSR) == 0xD0);
static_assert(offsetof(RccRegs, AHB3ENR) == 0xD4);
static_assert(offsetof(RccRegs, APB2ENR) == 0xF0);

struct PwrRegs {  // 0x58024800
  BV_RW CR1;
  BV_RW CSR1;  // ACTVOSRDY 13
  BV_RW CR2;
  BV_RW CR3;  // LDOEN 1, SCUEN 2, BYPASS 0
  BV_RW CPUCR;
  uint32_t reserved0;
  BV_RW D3CR;  // 0x18: VOS 15:14, VOSRDY 13
};
static_assert(offsetof(PwrRegs, D3CR) == 0x18);

struct FlashBankRegs {  // per bank: KEYR, OPTKEYR, CR, SR, CCR at +0x04..+0x14 (bank 2: +0x100)
  BV_RW ACR;            // only meaningful in bank 1's block
  BV_RW KEYR;
  BV_RW OPTKEYR;
  BV_RW CR;  // LOCK 0, PG 1, SER 2, PSIZE 5:4, FW 6, START 7, SNB 10:8
  BV_RW SR;  // BSY 0, WBNE 1, QW 2; error bits 17..26
  BV_RW CCR;
};
inline constexpr uint32_t kFlashCrLock = 1u << 0, kFlashCrPg = 1u << 1, kFlashCrSer = 1u << 2,
                          kFlashCrPsize64 = 3u << 4, kFlashCrStart = 1u << 7;
inline constexpr uint32_t kFlashSrQw = 1u << 2, kFlashSrBsy = 1u << 0;
inline constexpr uint32_t kFlashSrErrors = 0x07EE0000u;  // WRPERR..DBECCERR

struct GpioRegs {
  BV_RW MODER;
  BV_RW OTYPER;
  BV_RW OSPEEDR;
  BV_RW PUPDR;
  BV_RO IDR;
  BV_RW ODR;
  BV_RW BSRR;
  BV_RW LCKR;
  BV_RW AFR[2];
};

struct DcmiRegs {  // 0x48020000
  BV_RW CR;        // CAPTURE 0, CM 1, CROP 2, JPEG 3, ESS 4, PCKPOL 5, HSPOL 6, VSPOL 7, EDM 11:10,
                   // ENABLE 14
  BV_RO SR;
  BV_RO RIS;
  BV_RW IER;  // FRAME 0, OVR 1, ERR 2, VSYNC 3, LINE 4
  BV_RO MIS;
  BV_RW ICR;
  BV_RW ESCR;
  BV_RW ESUR;
  BV_RW CWSTRT;
  BV_RW CWSIZE;
  BV_RO DR;  // 0x28
};
static_assert(offsetof(DcmiRegs, DR) == 0x28);
inline constexpr uint32_t kDcmiFrame = 1u << 0, kDcmiOvr = 1u << 1, kDcmiErr = 1u << 2,
                          kDcmiVsync = 1u << 3;

struct DmaStreamRegs {
  BV_RW CR;  // EN 0, TEIE 2, TCIE 4, DIR 7:6, CIRC 8, PINC 9, MINC 10, PSIZE 12:11, MSIZE 14:13,
             // PL 17:16, DBM 18, CT 19, MBURST 24:23
  BV_RW NDTR;
  BV_RW PAR;
  BV_RW M0AR;
  BV_RW M1AR;
  BV_RW FCR;  // FTH 1:0, DMDIS 2
};
struct DmaRegs {  // DMA1 0x40020000, DMA2 0x40020400
  BV_RO LISR;     // streams 0..3: flags at bit 0, 6, 16, 22 (FEIF, -, DMEIF, TEIF, HTIF, TCIF)
  BV_RO HISR;
  BV_RW LIFCR;
  BV_RW HIFCR;
  DmaStreamRegs S[8];
};
static_assert(offsetof(DmaRegs, S) == 0x10 && sizeof(DmaStreamRegs) == 0x18);
inline constexpr uint32_t kDmaCrEn = 1u << 0, kDmaCrTeie = 1u << 2, kDmaCrHtie = 1u << 3,
                          kDmaCrTcie = 1u << 4, kDmaCrDirM2P = 1u << 6, kDmaCrCirc = 1u << 8,
                          kDmaCrMinc = 1u << 10, kDmaCrPsize32 = 2u << 11, kDmaCrMsize32 = 2u << 13,
                          kDmaCrPlHigh = 2u << 16, kDmaCrPlVeryHigh = 3u << 16,
                          kDmaCrDbm = 1u << 18, kDmaCrCt = 1u << 19, kDmaCrMburst4 = 1u << 23;
/// Bit offset of a stream's flags in LISR/HISR (and LIFCR/HIFCR).
constexpr uint32_t DmaFlagShift(int stream) {
  constexpr uint32_t kShift[4] = {0, 6, 16, 22};
  return kShift[stream & 3];
}
inline constexpr uint32_t kDmaFlagTc = 1u << 5, kDmaFlagHt = 1u << 4, kDmaFlagTe = 1u << 3,
                          kDmaFlagAll = 0x3Du;

struct DmamuxRegs {  // DMAMUX1 0x40020800: channel 0..7 = DMA1 stream 0..7, 8..15 = DMA2
  BV_RW CCR[16];     // DMAREQ_ID 7:0
};
inline constexpr uint32_t kDmamuxReqUsart1Rx = 41;
inline constexpr uint32_t kDmamuxReqUsart1Tx = 42;
inline constexpr uint32_t kDmamuxReqDcmi = 75;

struct UsartRegs {  // USART1 0x40011000
  BV_RW CR1;        // UE 0, RE 2, TE 3, IDLEIE 4, FIFOEN 29
  BV_RW CR2;
  BV_RW CR3;  // EIE 0, DMAR 6, DMAT 7, DDRE 13
  BV_RW BRR;
  BV_RW GTPR;
  BV_RW RTOR;
  BV_RW RQR;
  BV_RO ISR;  // PE 0, FE 1, NE 2, ORE 3, IDLE 4, RXNE 5, TC 6, TXE 7
  BV_RW ICR;  // PECF 0, FECF 1, NECF 2, ORECF 3, IDLECF 4 (same bits as ISR)
  BV_RO RDR;
  BV_RW TDR;  // 0x28
  BV_RW PRESC;
};
static_assert(offsetof(UsartRegs, TDR) == 0x28);
inline constexpr uint32_t kUsartCr1Ue = 1u << 0, kUsartCr1Re = 1u << 2, kUsartCr1Te = 1u << 3,
                          kUsartCr1Idleie = 1u << 4;
inline constexpr uint32_t kUsartCr3Eie = 1u << 0, kUsartCr3Dmar = 1u << 6, kUsartCr3Dmat = 1u << 7;
inline constexpr uint32_t kUsartPe = 1u << 0, kUsartFe = 1u << 1, kUsartNe = 1u << 2,
                          kUsartOre = 1u << 3, kUsartIdle = 1u << 4, kUsartRxne = 1u << 5;

struct TimRegs {  // TIM2 0x40000000 (32-bit)
  BV_RW CR1;
  BV_RW CR2;
  BV_RW SMCR;
  BV_RW DIER;
  BV_RW SR;
  BV_RW EGR;
  BV_RW CCMR1;
  BV_RW CCMR2;
  BV_RW CCER;
  BV_RW CNT;  // 0x24
  BV_RW PSC;
  BV_RW ARR;
};
static_assert(offsetof(TimRegs, CNT) == 0x24);

struct IwdgRegs {  // IWDG1 0x58004800
  BV_RW KR;
  BV_RW PR;
  BV_RW RLR;
  BV_RO SR;
  BV_RW WINR;
};

struct FmcRegs {  // 0x52004000
  BV_RW BCR1;     // FMCEN 31
  uint32_t reserved0[79];
  BV_RW SDCR[2];  // 0x140
  BV_RW SDTR[2];  // 0x148
  BV_RW SDCMR;    // 0x150
  BV_RW SDRTR;    // 0x154
  BV_RO SDSR;     // 0x158
};
static_assert(offsetof(FmcRegs, SDCR) == 0x140 && offsetof(FmcRegs, SDSR) == 0x158);

#undef BV_RW
#undef BV_RO

/// A buffer or register address as the 32-bit bus address a DMA register takes (host tests:
/// the low half, which the register fakes compare).
inline uint32_t BusAddress(const volatile void* p) {
  return static_cast<uint32_t>(reinterpret_cast<uintptr_t>(p));
}

template <typename T>
inline T* Reg(uintptr_t address) {
  return reinterpret_cast<T*>(address);
}
inline ItmRegs* const kItm = Reg<ItmRegs>(0xE0000000u);
inline RccRegs* const kRcc = Reg<RccRegs>(0x58024400u);
inline PwrRegs* const kPwr = Reg<PwrRegs>(0x58024800u);
inline FlashBankRegs* const kFlashBank1 = Reg<FlashBankRegs>(0x52002000u);
inline FlashBankRegs* const kFlashBank2 = Reg<FlashBankRegs>(0x52002100u);
inline GpioRegs* Gpio(int port) { return Reg<GpioRegs>(0x58020000u + 0x400u * port); }
inline DcmiRegs* const kDcmi = Reg<DcmiRegs>(0x48020000u);
inline DmaRegs* const kDma1 = Reg<DmaRegs>(0x40020000u);
inline DmaRegs* const kDma2 = Reg<DmaRegs>(0x40020400u);
inline DmamuxRegs* const kDmamux1 = Reg<DmamuxRegs>(0x40020800u);
inline UsartRegs* const kUsart1 = Reg<UsartRegs>(0x40011000u);
inline TimRegs* const kTim2 = Reg<TimRegs>(0x40000000u);
inline IwdgRegs* const kIwdg1 = Reg<IwdgRegs>(0x58004800u);
inline FmcRegs* const kFmc = Reg<FmcRegs>(0x52004000u);

// Interrupt numbers (RM0433 table 143).
inline constexpr int kIrqDma1Stream0 = 11;
inline constexpr int kIrqDma1Stream1 = 12;
inline constexpr int kIrqUsart1 = 37;
inline constexpr int kIrqDma2Stream1 = 57;
inline constexpr int kIrqDcmi = 78;
inline constexpr int kIrqCount = 150;

inline void NvicEnable(int irq) { cm7::NvicEnable(*kNvic, irq); }
inline void NvicPriority(int irq, uint8_t prio) { cm7::NvicPriority(*kNvic, irq, prio); }

using cm7::IrqLock;
using cm7::IrqRestore;
using cm7::IrqSave;

// D-cache maintenance by address (32-byte lines) around DMA buffers. Host builds (driver tests
// against register fakes) have no cache to maintain.
inline constexpr uintptr_t kCacheLine = 32;
#if defined(__arm__)
inline void DcacheClean(const void* p, size_t n) {
  uintptr_t a = reinterpret_cast<uintptr_t>(p) & ~(kCacheLine - 1);
  const uintptr_t end = reinterpret_cast<uintptr_t>(p) + n;
  asm volatile("dsb" ::: "memory");
  for (; a < end; a += kCacheLine) kScb->DCCMVAC = static_cast<uint32_t>(a);
  asm volatile("dsb\n isb" ::: "memory");
}
inline void DcacheInvalidate(const void* p, size_t n) {
  uintptr_t a = reinterpret_cast<uintptr_t>(p) & ~(kCacheLine - 1);
  const uintptr_t end = reinterpret_cast<uintptr_t>(p) + n;
  asm volatile("dsb" ::: "memory");
  for (; a < end; a += kCacheLine) kScb->DCIMVAC = static_cast<uint32_t>(a);
  asm volatile("dsb\n isb" ::: "memory");
}
#else
inline void DcacheClean(const void*, size_t) {}
inline void DcacheInvalidate(const void*, size_t) {}
#endif

}  // namespace bv::h7
