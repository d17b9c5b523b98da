# Bare-metal arm-none-eabi (GCC + newlib-nano). A per-core file sets BV_CPU_FLAGS and includes
# this one. No nosys.specs: an unresolved _sbrk is one of the two heap guards (see firmware/).
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

set(BV_TRIPLE arm-none-eabi)
find_program(CMAKE_C_COMPILER ${BV_TRIPLE}-gcc REQUIRED)
find_program(CMAKE_CXX_COMPILER ${BV_TRIPLE}-g++ REQUIRED)
find_program(CMAKE_ASM_COMPILER ${BV_TRIPLE}-gcc REQUIRED)
find_program(CMAKE_OBJCOPY ${BV_TRIPLE}-objcopy REQUIRED)
find_program(CMAKE_SIZE ${BV_TRIPLE}-size REQUIRED)
find_program(CMAKE_NM ${BV_TRIPLE}-nm REQUIRED)

# Compiler checks cannot link without startup code.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

set(BV_COMMON_FLAGS "${BV_CPU_FLAGS} -ffunction-sections -fdata-sections -fno-math-errno")
set(CMAKE_C_FLAGS_INIT "${BV_COMMON_FLAGS}")
set(CMAKE_CXX_FLAGS_INIT
    "${BV_COMMON_FLAGS} -fno-exceptions -fno-rtti -fno-threadsafe-statics -fno-use-cxa-atexit")
set(CMAKE_ASM_FLAGS_INIT "${BV_CPU_FLAGS}")
set(CMAKE_EXE_LINKER_FLAGS_INIT "${BV_CPU_FLAGS} -nostartfiles -specs=nano.specs -Wl,--gc-sections")

# Programs run on the build host; headers-only packages such as Eigen come from the host's
# /usr/share (their CMake config is architecture-independent); libraries never do.
set(CMAKE_FIND_ROOT_PATH /usr/share /usr)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
