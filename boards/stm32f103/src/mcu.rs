//! What every board shares: the clocks, the bxCAN with its transceiver, the parameter flash, the
//! independent watchdog, the reset cause, the unique ID and the variant straps.

use board_plan::mailbox;
use board_plan::reset::ResetCause;
use board_plan::rxq::RxRing;
use board_plan::straps::Straps;
use core::cell::UnsafeCell;
use embassy_stm32::gpio::AnyPin;
use embassy_stm32::interrupt::{self, InterruptExt};
use embassy_stm32::pac::iwdg::vals::{Key, Pr};
use embassy_stm32::peripherals::{CAN, FLASH, IWDG, PA11, PA12, PB5};
use embassy_stm32::rcc::{AHBPrescaler, APBPrescaler, Hse, HseMode, Pll, PllMul, PllPreDiv, PllSource, Sysclk};
use embassy_stm32::time::Hertz;
use embassy_stm32::{pac, rcc, Config, Peri};
use embassy_sync::waitqueue::AtomicWaker;

use crate::flash::Flash;
use crate::pin::OutPin;

/// Woken by the transmit interrupt: a mailbox's request completed (sent or aborted).
pub static TX_DONE: AtomicWaker = AtomicWaker::new();

/// The frames received and not yet taken, filled by the receive interrupts: reached only through
/// [`Rx::with`].
pub static RX: Rx = Rx(UnsafeCell::new(RxRing::new()));

/// The receive ring, shared by the receive interrupts and the main loop.
pub struct Rx(UnsafeCell<RxRing>);

// SAFETY: the ring is only reached through `Rx::with`, inside a critical section.
unsafe impl Sync for Rx {}

impl Rx {
    /// Runs `f` on the ring with interrupts off.
    pub fn with<R>(&self, f: impl FnOnce(&mut RxRing) -> R) -> R {
        // SAFETY: single core, interrupts off for the whole call, and `f` cannot reach `RX` again
        // (it gets the ring, not the static; the ring's methods do not call back), so the
        // reference is the only one while it lives (what a RefCell's borrow flag would check).
        critical_section::with(|_| f(unsafe { &mut *self.0.get() }))
    }
}

/// Woken by the receive interrupts: frames arrived in [`RX`].
pub static RX_READY: AtomicWaker = AtomicWaker::new();

/// The bxCAN transmit interrupt (the vector table names it): acknowledges every completed
/// request and wakes [`TX_DONE`].
#[no_mangle]
unsafe extern "C" fn USB_HP_CAN1_TX() {
    pac::CAN.tsr().write(|w| {
        for i in 0..3 {
            w.set_rqcp(i, true);
        }
    });
    TX_DONE.wake();
}

/// The bxCAN FIFO 0 interrupt: moves the FIFO's frames into [`RX`].
#[no_mangle]
unsafe extern "C" fn USB_LP_CAN1_RX0() {
    receive(0);
}

/// The bxCAN FIFO 1 interrupt (every filter bank feeds FIFO 0; served all the same).
#[no_mangle]
unsafe extern "C" fn CAN1_RX1() {
    receive(1);
}

/// Moves every frame of receive FIFO `fifo` into [`RX`], releasing each from the FIFO (only
/// RFOM written: the overrun flag stays for the main loop to report), and wakes [`RX_READY`].
fn receive(fifo: usize) {
    let can = pac::CAN;
    while can.rfr(fifo).read().fmp() != 0 {
        let mb = can.rx(fifo);
        let frame = mailbox::frame_of([mb.rir().read().0, mb.rdtr().read().0, mb.rdlr().read().0, mb.rdhr().read().0]);
        can.rfr(fifo).write(|w| w.set_rfom(true));
        RX.with(|rx| rx.push(frame));
    }
    RX_READY.wake();
}

/// The watchdog's timeout: the main loop turns at least once per sample period (1 ms) and a
/// parameter save (one 1 KiB page erased, at most 40 ms on the F103, plus the writes) is the
/// longest it is busy, so 256 ms only expires when the loop is stuck.
pub const WATCHDOG_TIMEOUT_US: u32 = 256_000;

/// The clocks of every board: 8 MHz HSE crystal, PLL ×9 = 72 MHz SYSCLK and AHB, APB2 72 MHz,
/// APB1 36 MHz (the bxCAN clock `board_plan::timing::APB1_HZ` computes the bit timing for).
pub fn config() -> Config {
    let mut config = Config::default();
    config.rcc.hse = Some(Hse { freq: Hertz(8_000_000), mode: HseMode::Oscillator });
    config.rcc.pll = Some(Pll { src: PllSource::HSE, prediv: PllPreDiv::DIV1, mul: PllMul::MUL9 });
    config.rcc.sys = Sysclk::PLL1_P;
    config.rcc.ahb_pre = AHBPrescaler::DIV1;
    config.rcc.apb1_pre = APBPrescaler::DIV2;
    config.rcc.apb2_pre = APBPrescaler::DIV1;
    config
}

/// What the RCC recorded as the cause of this reset; clears the flags, so the next reset
/// records its own cause.
pub fn take_reset_cause() -> ResetCause {
    let csr = pac::RCC.csr().read().0;
    pac::RCC.csr().modify(|w| w.set_rmvf(true));
    ResetCause::from_csr(csr)
}

/// Reads the four variant straps (PB12..PB15) once: pull-ups on, 10 µs to settle, read, pins
/// released (a fitted strap draws no current afterwards).
pub fn read_straps(pins: [Peri<'_, AnyPin>; 4]) -> Straps {
    Straps(crate::pin::read_pulled_up(&pins, embassy_time::Duration::from_micros(10)))
}

/// The bxCAN, in sleep mode until the firmware configures and enables it, through its registers
/// (`pac::CAN`): the board's own interrupt handlers above serve it, and the firmware polls its
/// error state, so nothing of Embassy's CAN driver (its handlers, wakers and reference counts) is
/// linked. The set-up is the driver's `Can::new` without the status-change interrupt, which
/// only woke the driver's own wakers: PA11 (RX) floating input, PA12 (TX) alternate-function
/// push-pull 50 MHz (no remap, as after reset), the clock on and the controller reset, the
/// FIFO and mailbox interrupts enabled, time stamps on, then sleep mode.
pub struct CanPeri(Peri<'static, CAN>);

impl CanPeri {
    fn new(can: Peri<'static, CAN>, _rx: Peri<'static, PA11>, _tx: Peri<'static, PA12>) -> CanPeri {
        // CRH: PA11 CNF 01 MODE 00 (floating input), PA12 CNF 10 MODE 11 (AF push-pull).
        pac::GPIOA.cr(1).modify(|w| w.0 = (w.0 & !(0xFF << 12)) | (0x4 << 12) | (0xB << 16));
        rcc::enable_and_reset::<CAN>();
        let regs = pac::CAN;
        regs.ier().write(|w| {
            w.set_fmpie(0, true);
            w.set_fmpie(1, true);
            w.set_tmeie(true);
        });
        regs.mcr().write(|w| w.set_ttcm(true));
        for irq in [interrupt::USB_HP_CAN1_TX, interrupt::USB_LP_CAN1_RX0, interrupt::CAN1_RX1] {
            irq.unpend();
            // SAFETY: the handlers above serve these interrupts; none runs in a critical section
            // of the firmware's that it could break.
            unsafe { irq.enable() };
        }
        can_sleep();
        CanPeri(can)
    }
}

/// Requests the bxCAN's sleep mode, leaving initialisation mode (MCR SLEEP set, INRQ clear), and
/// waits until the controller is there (MSR SLAK set, INAK clear); the end of the set-up and of
/// every bit-timing change (RM0008 24.4).
pub fn can_sleep() {
    let regs = pac::CAN;
    regs.mcr().modify(|w| {
        w.set_sleep(true);
        w.set_inrq(false);
    });
    while {
        let msr = regs.msr().read();
        !msr.slak() || msr.inak()
    } {}
}

/// The independent watchdog, through its registers: the prescaler and reload value for
/// [`WATCHDOG_TIMEOUT_US`] are constants (`board_plan::watchdog`), where Embassy's
/// `IndependentWatchdog::new` computed them at run time; the register writes are its.
pub struct Watchdog(Peri<'static, IWDG>);

impl Watchdog {
    fn new(iwdg: Peri<'static, IWDG>) -> Watchdog {
        const REGISTERS: (u8, u16) = board_plan::watchdog::registers(WATCHDOG_TIMEOUT_US);
        let regs = pac::IWDG;
        regs.kr().write(|w| w.set_key(Key::ENABLE));
        regs.pr().write(|w| w.set_pr(Pr::from_bits(REGISTERS.0)));
        regs.rlr().write(|w| w.set_rl(REGISTERS.1));
        Watchdog(iwdg)
    }

    /// Starts the watchdog: from now on the MCU resets unless [`Watchdog::pet`] comes in time.
    pub fn unleash(&mut self) {
        pac::IWDG.kr().write(|w| w.set_key(Key::START));
    }

    /// Restarts the watchdog's count.
    pub fn pet(&mut self) {
        pac::IWDG.kr().write(|w| w.set_key(Key::RESET));
    }
}

/// The peripherals every board has.
pub struct Mcu {
    /// The bxCAN, in sleep mode until the firmware configures and enables it.
    pub can: CanPeri,
    /// The transceiver's standby pin (high = standby): the firmware drives it low once the
    /// controller runs.
    pub standby: OutPin,
    /// The flash; the parameter pages are the region `memory.x` reserves.
    pub flash: Flash,
    /// The independent watchdog, not yet started.
    pub watchdog: Watchdog,
    /// Why the MCU reset.
    pub reset: ResetCause,
    /// The MCU's 96-bit unique device ID.
    pub uid: [u8; 12],
}

impl Mcu {
    /// Takes the shared peripherals.
    pub fn new(
        can: Peri<'static, CAN>,
        rx: Peri<'static, PA11>,
        tx: Peri<'static, PA12>,
        standby: Peri<'static, PB5>,
        flash: Peri<'static, FLASH>,
        iwdg: Peri<'static, IWDG>,
    ) -> Mcu {
        let reset = take_reset_cause();
        // Standby until the controller is configured: a board never disturbs the bus at reset.
        let standby = OutPin::new(standby.into(), true);
        Mcu {
            can: CanPeri::new(can, rx, tx),
            standby,
            flash: Flash::new(flash),
            watchdog: Watchdog::new(iwdg),
            reset,
            uid: embassy_stm32::uid::uid(),
        }
    }
}

/// Sends `out` on `spi` (a master, enabled) and returns the byte received meanwhile: waits for
/// room in the transmit buffer, writes, waits for the received byte and reads it (reading it
/// also keeps the SPI from an overrun).
pub(crate) fn spi_exchange(spi: pac::spi::Spi, out: u8) -> u8 {
    while !spi.sr().read().txe() {}
    spi.dr().write(|w| w.set_dr(out as u16));
    while !spi.sr().read().rxne() {}
    spi.dr().read().dr() as u8
}
