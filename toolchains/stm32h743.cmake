# STM32H743: Cortex-M7 r1, FPv5 double precision (same multilib as the QEMU build).
set(BV_CPU_FLAGS "-mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard")
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi.cmake)
