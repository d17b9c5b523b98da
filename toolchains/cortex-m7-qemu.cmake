# QEMU mps2-an500: Cortex-M7 with double-precision FPv5 (multilib thumb/v7e-m+dp/hard).
set(BV_CPU_FLAGS "-mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard")
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi.cmake)
