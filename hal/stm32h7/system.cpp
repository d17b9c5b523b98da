#include "hal/stm32h7/system.h"

#include "hal/stm32h7/registers.h"

namespace bv::h7 {
namespace {

// Pin map of the carrier board: port index (A=0), pin mask, alternate function.
struct PinGroup {
  uint8_t port;
  uint16_t mask;
  uint8_t af;
};
constexpr uint8_t kAfUsart1 = 7, kAfFmc = 12, kAfDcmi = 13;
constexpr PinGroup kPins[] = {
    {0, (1u << 9) | (1u << 10), kAfUsart1},           // PA9 TX, PA10 RX
    {0, (1u << 4) | (1u << 6), kAfDcmi},              // PA4 HSYNC, PA6 PIXCLK
    {1, (1u << 7) | (1u << 8) | (1u << 9), kAfDcmi},  // PB7 VSYNC, PB8 D6, PB9 D7
    {2, (1u << 6) | (1u << 7) | (1u << 8) | (1u << 9) | (1u << 11),
     kAfDcmi},              // PC6..9 D0..3, PC11 D4
    {3, 1u << 3, kAfDcmi},  // PD3 D5
    {3, 0xC703, kAfFmc},    // PD0,1,8,9,10,14,15
    {4, 0xFF83, kAfFmc},    // PE0,1,7..15
    {5, 0xF83F, kAfFmc},    // PF0..5,11..15
    {6, 0x8137, kAfFmc},    // PG0,1,2,4,5,8,15
    {7, 0x002C, kAfFmc},    // PH2 SDCKE0, PH3 SDNE0, PH5 SDNWE
};

void WaitSet(volatile uint32_t& reg, uint32_t mask) {
  while ((reg & mask) == 0) {
  }
}

}  // namespace

void DelayCycles(uint32_t cycles) {
  for (uint32_t i = 0; i < cycles / 4; ++i) asm volatile("nop");
}

void ClockTreeInit() {
  // Supply: LDO, then voltage scale 1 (required for 400 MHz).
  kPwr->CR3 = (kPwr->CR3 & ~0x7u) | (1u << 1);
  WaitSet(kPwr->CSR1, 1u << 13);
  kPwr->D3CR = (kPwr->D3CR & ~(3u << 14)) | (3u << 14);
  WaitSet(kPwr->D3CR, 1u << 13);

  kRcc->CR = kRcc->CR | (1u << 16);  // HSE on
  WaitSet(kRcc->CR, 1u << 17);
  // PLL1: 25 MHz / 5 = 5 MHz ref (range 4-8 MHz), x160 = 800 MHz VCO, P /2 = 400, Q /4 = 200.
  kRcc->PLLCKSELR = (2u << 0) | (5u << 4);
  kRcc->PLLCFGR = (kRcc->PLLCFGR & ~0xFu) | (2u << 2) | (1u << 16) | (1u << 17) | (1u << 18);
  kRcc->PLL1DIVR = (159u << 0) | (1u << 9) | (3u << 16) | (1u << 24);
  kRcc->CR = kRcc->CR | (1u << 24);
  WaitSet(kRcc->CR, 1u << 25);

  // Flash: 2 wait states, programming delay 2 for a 200 MHz AXI clock at VOS1 (RM0433 t.17).
  kFlashBank1->ACR = (2u << 0) | (2u << 4);
  while ((kFlashBank1->ACR & 0xFu) != 2u) {
  }
  kRcc->D1CFGR = (0u << 8) | (8u << 0) | (4u << 4);  // CPU /1, AHB /2, APB3 /2
  kRcc->D2CFGR = (4u << 4) | (4u << 8);              // APB1 /2, APB2 /2
  kRcc->D3CFGR = (4u << 4);                          // APB4 /2
  kRcc->CFGR = (kRcc->CFGR & ~7u) | 3u;              // SYSCLK = PLL1P
  while (((kRcc->CFGR >> 3) & 7u) != 3u) {
  }
}

void PinsInit() {
  kRcc->AHB4ENR = kRcc->AHB4ENR | 0xFFu;  // GPIOA..H
  (void)kRcc->AHB4ENR;
  for (const PinGroup& g : kPins) {
    GpioRegs* gpio = Gpio(g.port);
    for (int pin = 0; pin < 16; ++pin) {
      if ((g.mask & (1u << pin)) == 0) continue;
      gpio->MODER = (gpio->MODER & ~(3u << (2 * pin))) | (2u << (2 * pin));  // AF
      gpio->OSPEEDR = gpio->OSPEEDR | (3u << (2 * pin));                     // very high
      gpio->AFR[pin >> 3] =
          (gpio->AFR[pin >> 3] & ~(0xFu << (4 * (pin & 7)))) | (uint32_t{g.af} << (4 * (pin & 7)));
    }
  }
}

void SdramInit() {
  kRcc->AHB3ENR = kRcc->AHB3ENR | (1u << 12);  // FMC (kernel clock: HCLK3 = 200 MHz)
  (void)kRcc->AHB3ENR;
  // 9 column bits, 12 row bits, 32-bit, 4 banks, CAS 2, SDCLK = HCLK/2 = 100 MHz, read burst.
  kFmc->SDCR[0] =
      (1u << 0) | (1u << 2) | (2u << 4) | (1u << 6) | (2u << 7) | (2u << 10) | (1u << 12);
  // tMRD 2, tXSR 7, tRAS 4, tRC 7, tWR 3, tRP 2, tRCD 2 cycles (fields hold value - 1).
  kFmc->SDTR[0] =
      (1u << 0) | (6u << 4) | (3u << 8) | (6u << 12) | (2u << 16) | (1u << 20) | (1u << 24);
  kFmc->BCR1 = kFmc->BCR1 | (1u << 31);  // FMCEN
  auto command = [](uint32_t mode, uint32_t refresh, uint32_t mrd) {
    while (kFmc->SDSR & (1u << 5)) {
    }
    kFmc->SDCMR = mode | (1u << 4) /* bank 1 */ | ((refresh - 1) << 5) | (mrd << 9);
  };
  command(1, 1, 0);             // clock enable
  DelayCycles(kCpuHz / 10000);  // >= 100 us
  command(2, 1, 0);             // precharge all
  command(3, 8, 0);             // 8 auto-refresh cycles
  command(4, 1, 0x220);         // mode: burst 1, sequential, CAS 2, single write burst
  // 64 ms / 4096 rows at 100 MHz = 1562 cycles, minus the 20-cycle margin.
  kFmc->SDRTR = 1542u << 1;
}

void ItmWrite(const char* text) {
  if ((kItm->TCR & 1u) == 0 || (kItm->TER & 1u) == 0) return;
  for (; *text != '\0'; ++text) {
    while (kItm->PORT[0] == 0) {
    }
    *reinterpret_cast<volatile uint8_t*>(&kItm->PORT[0]) = static_cast<uint8_t>(*text);
  }
}

void SystemReset() {
  asm volatile("dsb" ::: "memory");
  kScb->AIRCR = (0x5FAu << 16) | (1u << 2);  // SYSRESETREQ
  asm volatile("dsb" ::: "memory");
  for (;;) {
  }
}

}  // namespace bv::h7
