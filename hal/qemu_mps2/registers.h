#pragma once
// CMSIS-style register overlays for the few Cortex-M7 core and MPS2 (AN500) peripherals the
// QEMU board uses. Debian ships no CMSIS headers; these follow the ARMv7-M ARM and the CMSDK
// APB peripheral TRM. Only the registers we touch are named.
#include <cstdint>

namespace bv::qemu {

#define BV_RW volatile uint32_t
#define BV_RO const volatile uint32_t

struct ScbRegs {  // System control block, 0xE000ED00
  BV_RO CPUID;
  BV_RW ICSR;
  BV_RW VTOR;
  BV_RW AIRCR;
  BV_RW SCR;
  BV_RW CCR;
  volatile uint8_t SHPR[12];
  BV_RW SHCSR;
  BV_RW CFSR;  // MMFSR | BFSR << 8 | UFSR << 16
  BV_RW HFSR;
  BV_RW DFSR;
  BV_RW MMFAR;
  BV_RW BFAR;
  BV_RW AFSR;
  uint32_t reserved0[18];
  BV_RW CPACR;  // 0xE000ED88
};
static_assert(__builtin_offsetof(ScbRegs, CFSR) == 0x28);
static_assert(__builtin_offsetof(ScbRegs, BFAR) == 0x38);
static_assert(__builtin_offsetof(ScbRegs, CPACR) == 0x88);

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
};

struct CmsdkUartRegs {  // CMSDK APB UART
  BV_RW DATA;
  BV_RW STATE;  // bit0 TX full, bit1 RX full, bit2 TX overrun, bit3 RX overrun
  BV_RW CTRL;   // bit0 TX enable, bit1 RX enable
  BV_RW INTSTATUS;
  BV_RW BAUDDIV;
};
inline constexpr uint32_t kUartStateTxFull = 1u << 0;
inline constexpr uint32_t kUartStateRxFull = 1u << 1;
inline constexpr uint32_t kUartCtrlTxEn = 1u << 0;
inline constexpr uint32_t kUartCtrlRxEn = 1u << 1;

struct CmsdkDualTimerRegs {  // CMSDK dual timer, timer 1 at +0x00
  BV_RW LOAD;
  BV_RO VALUE;
  BV_RW CONTROL;  // bit7 enable, bit6 periodic, bit5 IRQ, bit1 32-bit, bit0 one-shot
  BV_RW INTCLR;
  BV_RO RIS;
  BV_RO MIS;
  BV_RW BGLOAD;
};

#undef BV_RW
#undef BV_RO

inline ScbRegs* const kScb = reinterpret_cast<ScbRegs*>(0xE000ED00u);
inline SysTickRegs* const kSysTick = reinterpret_cast<SysTickRegs*>(0xE000E010u);
inline NvicRegs* const kNvic = reinterpret_cast<NvicRegs*>(0xE000E100u);
inline CmsdkUartRegs* const kUart0 = reinterpret_cast<CmsdkUartRegs*>(0x40004000u);
inline CmsdkDualTimerRegs* const kDualTimer1 = reinterpret_cast<CmsdkDualTimerRegs*>(0x40002000u);

inline constexpr uint32_t kTimerClockHz = 25000000;  // MPS2 peripheral clock (measured)

}  // namespace bv::qemu
