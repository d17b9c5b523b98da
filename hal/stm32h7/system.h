#pragma once
// STM32H743 bring-up: clock tree, external SDRAM, pins, debug log.
#include <cstdint>

namespace bv::h7 {

inline constexpr uint32_t kCpuHz = 400000000;    // PLL1P from HSE 25 MHz, VOS1
inline constexpr uint32_t kHclkHz = 200000000;   // AXI/AHB
inline constexpr uint32_t kPclkHz = 100000000;   // every APB
inline constexpr uint32_t kTimerHz = 200000000;  // APB timer kernel clock (2 x PCLK)

/// HSE 25 MHz -> PLL1 400 MHz CPU, 200 MHz AHB, 100 MHz APBs; flash wait states first.
void ClockTreeInit();
/// GPIO alternate functions for FMC (SDRAM), DCMI and USART1 (pin map: README.md).
void PinsInit();
/// FMC SDRAM bank 1 at 0xC0000000: 32 MB, 32-bit, SDCLK 100 MHz (IS42S32800-class part).
void SdramInit();
/// Text on ITM stimulus port 0 (SWO) when a debugger enabled it; otherwise nothing.
void ItmWrite(const char* text);
[[noreturn]] void SystemReset();
/// Busy wait used only during bring-up.
void DelayCycles(uint32_t cycles);

}  // namespace bv::h7
