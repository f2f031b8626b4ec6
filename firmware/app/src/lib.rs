//! Shared pieces of the kerf binaries: exit paths for the emulator and the
//! exception handlers that make a crash a failed run rather than a hang.
#![no_std]

pub mod bench;
pub mod inputs;
pub mod settings_file;
pub mod stack;
pub mod uart;

use cortex_m_semihosting::debug;

/// Ends the emulator run with success (`true`) or failure.
pub fn exit(success: bool) -> ! {
    debug::exit(if success {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    // Only reached when no debugger/emulator honours semihosting exit (a bare board).
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m_semihosting::hprintln!("panic: {}", info);
    exit(false)
}

#[cortex_m_rt::exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    cortex_m_semihosting::hprintln!("hard fault");
    exit(false)
}
