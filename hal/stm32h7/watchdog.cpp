#include "hal/stm32h7/watchdog.h"

#include "hal/stm32h7/registers.h"

namespace bv::h7 {

void IndependentWatchdog::Start() {
  kIwdg1->KR = 0xCCCC;  // start (LSI 32 kHz)
  kIwdg1->KR = 0x5555;  // unlock PR/RLR
  kIwdg1->PR = 2;       // /16 -> 2 kHz
  kIwdg1->RLR = 1000;   // 0.5 s
  while (kIwdg1->SR != 0) {
  }
  kIwdg1->KR = 0xAAAA;
}

void IndependentWatchdog::DoFeed() { kIwdg1->KR = 0xAAAA; }

}  // namespace bv::h7
