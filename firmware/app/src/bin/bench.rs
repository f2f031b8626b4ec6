#![no_std]
#![no_main]
use kerf_app as _;
#[cortex_m_rt::entry]
fn main() -> ! { kerf_app::exit(true) }
