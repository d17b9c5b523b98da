#pragma once
// CMSIS-style register overlays for the MPS2 (AN500) peripherals the QEMU board uses (the
// Cortex-M7 core registers are in hal/cortex_m/cortex_m7.h). Debian ships no CMSIS headers; these
// follow the ARMv7-M ARM and the CMSDK APB peripheral TRM. Only the registers we touch are named.
#include <cstdint>

#include "hal/cortex_m/cortex_m7.h"

namespace bv::qemu {

using cm7::kNvic;
using cm7::kScb;
using cm7::kSysTick;
using cm7::NvicRegs;
using cm7::ScbRegs;
using cm7::SysTickRegs;

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
inline constexpr uint32_t kUartStateRxOverrun = 1u << 3;  // write 1 to clear
inline constexpr uint32_t kUartCtrlRxEn = 1u << 1;
inline constexpr uint32_t kUartCtrlRxIntEn = 1u << 3;
inline constexpr uint32_t kUartIntRx = 1u << 1;  // INTSTATUS, write 1 to clear
inline constexpr int kIrqUart0Rx = 0;            // AN500: UART0 RX = IRQ 0, TX = IRQ 1

struct CmsdkDualTimerRegs {  // CMSDK dual timer, timer 1 at +0x00
  BV_RW LOAD;
  BV_RO VALUE;
  BV_RW CONTROL;  // bit7 enable, bit6 periodic, bit5 IRQ, bit1 32-bit, bit0 one-shot
  BV_RW INTCLR;
  BV_RO RIS;
  BV_RO MIS;
  BV_RW BGLOAD;
};

inline CmsdkUartRegs* const kUart0 = reinterpret_cast<CmsdkUartRegs*>(0x40004000u);
inline CmsdkDualTimerRegs* const kDualTimer1 = reinterpret_cast<CmsdkDualTimerRegs*>(0x40002000u);

inline constexpr uint32_t kTimerClockHz = 25000000;  // MPS2 peripheral clock (measured)

}  // namespace bv::qemu
