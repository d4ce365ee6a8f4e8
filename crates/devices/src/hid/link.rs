//! A HID device read on its own thread: reports go to the haptic thread through an `rtrb` queue,
//! so `poll` never blocks, locks or allocates. When the device stops answering (unplugged), the
//! link says so at once and the thread looks for it again every 200 ms, so a session picks it
//! up when it is plugged back in.
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

/// Where reports come from: hidapi, or recorded bytes in tests.
pub trait ReportSource: Send {
    /// One report into `buf` (its length), 0 when none came within `timeout_ms`; `Err` when the
    /// device is gone.
    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, ()>;
}

/// Finds and opens the device (again, after an unplug); `None` while it is absent.
pub trait Opener: Send + 'static {
    fn open(&mut self) -> Option<Box<dyn ReportSource>>;
}

/// Longest report kept (SpaceMouse 13 bytes, keyboards 9).
pub const REPORT_MAX: usize = 32;

#[derive(Clone, Copy)]
pub struct Report {
    pub len: u8,
    pub bytes: [u8; REPORT_MAX],
}

impl Report {
    pub fn as_slice(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len).min(REPORT_MAX)]
    }
}

struct Status {
    connected: AtomicBool,
    stop: AtomicBool,
    /// Bumped on every (re)open.
    generation: AtomicU64,
    unplugs: AtomicU64,
}

/// The haptic thread's end of a HID device.
pub struct HidLink {
    reports: rtrb::Consumer<Report>,
    status: Arc<Status>,
    io: Option<JoinHandle<()>>,
}

const QUEUE: usize = 1024;
const RETRY: Duration = Duration::from_millis(200);

impl HidLink {
    /// Opens the device now (an error if it is absent) and starts its reader thread.
    pub fn start(mut opener: impl Opener, name: &str) -> Option<HidLink> {
        let first = opener.open()?;
        let (mut tx, reports) = rtrb::RingBuffer::new(QUEUE);
        let status = Arc::new(Status {
            connected: AtomicBool::new(true),
            stop: AtomicBool::new(false),
            generation: AtomicU64::new(1),
            unplugs: AtomicU64::new(0),
        });
        let s = status.clone();
        let io = std::thread::Builder::new()
            .name(format!("dentsim-hid-{name}"))
            .spawn(move || {
                let mut source = Some(first);
                let mut buf = [0u8; REPORT_MAX];
                while !s.stop.load(Ordering::Acquire) {
                    let Some(src) = source.as_mut() else {
                        std::thread::sleep(RETRY);
                        source = opener.open();
                        if source.is_some() {
                            s.generation.fetch_add(1, Ordering::AcqRel);
                            s.connected.store(true, Ordering::Release);
                        }
                        continue;
                    };
                    match src.read(&mut buf, 10) {
                        Ok(0) => {}
                        Ok(n) => {
                            let mut r = Report { len: n.min(REPORT_MAX) as u8, bytes: [0; REPORT_MAX] };
                            r.bytes[..usize::from(r.len)].copy_from_slice(&buf[..usize::from(r.len)]);
                            let _ = tx.push(r);
                        }
                        Err(()) => {
                            s.connected.store(false, Ordering::Release);
                            s.unplugs.fetch_add(1, Ordering::Relaxed);
                            source = None;
                        }
                    }
                }
            })
            .ok()?;
        Some(HidLink { reports, status, io: Some(io) })
    }

    /// Hands every queued report to `f`; then whether the device is there.
    pub fn drain(&mut self, mut f: impl FnMut(&[u8])) -> bool {
        while let Ok(r) = self.reports.pop() {
            f(r.as_slice());
        }
        self.status.connected.load(Ordering::Acquire)
    }

    pub fn generation(&self) -> u64 {
        self.status.generation.load(Ordering::Acquire)
    }

    pub fn unplugs(&self) -> u64 {
        self.status.unplugs.load(Ordering::Relaxed)
    }
}

impl Drop for HidLink {
    fn drop(&mut self) {
        self.status.stop.store(true, Ordering::Release);
        if let Some(h) = self.io.take() {
            let _ = h.join();
        }
    }
}

/// hidapi: the first plugged-in device for which `wanted(vendor, product)` holds (hidraw).
pub struct HidapiOpener<F: Fn(u16, u16) -> bool + Send + 'static> {
    api: Option<hidapi::HidApi>,
    wanted: F,
}

impl<F: Fn(u16, u16) -> bool + Send + 'static> HidapiOpener<F> {
    pub fn new(wanted: F) -> Self {
        HidapiOpener { api: hidapi::HidApi::new().ok(), wanted }
    }
}

struct HidapiSource(hidapi::HidDevice);

impl ReportSource for HidapiSource {
    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, ()> {
        self.0.read_timeout(buf, timeout_ms).map_err(|_| ())
    }
}

impl<F: Fn(u16, u16) -> bool + Send + 'static> Opener for HidapiOpener<F> {
    fn open(&mut self) -> Option<Box<dyn ReportSource>> {
        let api = self.api.as_mut()?;
        api.refresh_devices().ok()?;
        let info = api.device_list().find(|d| (self.wanted)(d.vendor_id(), d.product_id()))?;
        let dev = info.open_device(api).ok()?;
        Some(Box::new(HidapiSource(dev)))
    }
}

/// Recorded reports played back as a device, for tests and demos: each session of `plugs` is
/// one time plugged in (its reports, one per read, then the device is pulled out).
pub struct Recorded {
    pub plugs: std::collections::VecDeque<Vec<Vec<u8>>>,
    /// Reads to wait (answering "no report") before each report, so a reader sees them spread.
    pub gap_reads: usize,
}

struct RecordedSource {
    reports: std::collections::VecDeque<Vec<u8>>,
    gap: usize,
    wait: usize,
}

impl ReportSource for RecordedSource {
    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, ()> {
        if self.wait > 0 {
            self.wait -= 1;
            std::thread::sleep(Duration::from_millis(timeout_ms.max(0) as u64));
            return Ok(0);
        }
        self.wait = self.gap;
        let r = self.reports.pop_front().ok_or(())?;
        let n = r.len().min(buf.len());
        buf[..n].copy_from_slice(&r[..n]);
        Ok(n)
    }
}

impl Opener for Recorded {
    fn open(&mut self) -> Option<Box<dyn ReportSource>> {
        let reports = self.plugs.pop_front()?.into();
        Some(Box::new(RecordedSource { reports, gap: self.gap_reads, wait: self.gap_reads }))
    }
}
