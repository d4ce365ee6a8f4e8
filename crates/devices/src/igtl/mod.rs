//! A force-feedback arm bridged over OpenIGTLink (as 3D Slicer, PLUS and the CRTK bridges do):
//! dentsim connects as a client, takes the tool pose from TRANSFORM or POSITION messages and
//! answers every pose with the latest force as a SENSOR message of six values (fx fy fz in N,
//! tx ty tz in N·mm, as `servo_cf`).
//!
//! Threads: the socket belongs to an I/O thread; the haptic thread only pops poses from one
//! `rtrb` queue and pushes forces into another, so it never blocks, locks or allocates. The I/O
//! thread answers a pose at once with the newest force the haptic thread produced (one tick old
//! at most), so the round trip does not wait for a tick.
//!
//! Faults: a malformed message (bad CRC, bad layout, NaN or non-rotation pose) is dropped and
//! counted; unknown types are skipped; a body larger than `max_body` ends the connection. When
//! no pose arrives for `stall` ms, or the link breaks, `poll` reports a fault, the session sends
//! zero force that tick, and the I/O thread reconnects. The session ends when the peer closes the
//! connection in order (end of stream), or on [`request_stop`].
pub mod codec;

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use glam::{DAffine3, DVec3};

use crate::error::{Error, Result};
use crate::{Device, DeviceState, Fault, BUTTON_CUT, DEFAULT_RPM};
use codec::{Header, Malformed, HEADER_SIZE, SENSOR_MESSAGE_MAX};

/// Set by Ctrl-C (the CLI's handler): every live device reports finished, so sessions end and
/// write their outputs.
static STOP_ALL: AtomicBool = AtomicBool::new(false);

/// Ends every live device's session (signal-safe: one atomic store).
pub fn request_stop() {
    STOP_ALL.store(true, Ordering::Release);
}

/// How to reach the bridge and read it (`igtl://HOST:PORT?pose=NAME&force=NAME&pedal=1&stall=MS`).
#[derive(Clone, Debug, PartialEq)]
pub struct IgtlOptions {
    pub host: String,
    pub port: u16,
    /// Take poses only from this device name (default: any).
    pub pose_name: Option<String>,
    /// Device name of the SENSOR messages sent back.
    pub force_name: String,
    /// Hold cut mode on (the bridge has no pedal of its own).
    pub pedal: bool,
    /// No pose for this long (ms) is a fault: force zero.
    pub stall_ms: f64,
    /// No byte at all for this long (ms) drops the connection and reconnects.
    pub silence_ms: f64,
    /// Bodies larger than this (bytes) end the connection: nothing a tracker sends is near it.
    pub max_body: u64,
    /// How long the first connection may take (ms) before opening fails.
    pub connect_ms: f64,
}

impl Default for IgtlOptions {
    fn default() -> Self {
        IgtlOptions {
            host: "127.0.0.1".into(),
            port: codec::DEFAULT_PORT,
            pose_name: None,
            force_name: "Force".into(),
            pedal: false,
            stall_ms: 100.0,
            silence_ms: 1000.0,
            max_body: 16 << 20,
            connect_ms: 5000.0,
        }
    }
}

/// The URL's option keys, for help texts.
pub const IGTL_KEYS: &str = "pose=NAME, force=NAME (default Force), pedal=0|1, stall=MS (100), silence=MS (1000), \
                             max_body=BYTES (16 MiB), connect=MS (5000)";

impl IgtlOptions {
    /// Parses what follows `igtl://`; errors name the field.
    pub fn parse(rest: &str) -> std::result::Result<Self, String> {
        let mut o = IgtlOptions::default();
        let (addr, query) = rest.split_once('?').unwrap_or((rest, ""));
        let addr = addr.trim_end_matches('/');
        if !addr.is_empty() {
            let (host, port) = match addr.rsplit_once(':') {
                Some((h, p)) => (h, Some(p)),
                None => (addr, None),
            };
            if !host.is_empty() {
                o.host = host.trim_start_matches('[').trim_end_matches(']').to_string();
            }
            if let Some(p) = port {
                o.port = p.parse().ok().filter(|&p| p > 0).ok_or_else(|| format!("port '{p}' is not 1..65535"))?;
            }
        }
        for pair in query.split('&').filter(|s| !s.is_empty()) {
            let (key, value) = pair.split_once('=').ok_or_else(|| format!("'{pair}' is not KEY=VALUE"))?;
            let ms = || -> std::result::Result<f64, String> {
                value.parse::<f64>().ok().filter(|v| v.is_finite() && *v > 0.0).ok_or_else(|| format!("field '{key}': '{value}', expected milliseconds > 0"))
            };
            match key {
                "pose" if !value.is_empty() => o.pose_name = Some(value.to_string()),
                "force" if !value.is_empty() && value.len() <= 20 => o.force_name = value.to_string(),
                "pose" | "force" => return Err(format!("field '{key}': '{value}', expected a device name of 1 to 20 characters")),
                "pedal" => {
                    o.pedal = match value {
                        "0" => false,
                        "1" => true,
                        _ => return Err(format!("field 'pedal': '{value}', expected 0 or 1")),
                    }
                }
                "stall" => o.stall_ms = ms()?,
                "silence" => o.silence_ms = ms()?,
                "connect" => o.connect_ms = ms()?,
                "max_body" => o.max_body = value.parse().ok().filter(|&v| v >= 64).ok_or_else(|| format!("field 'max_body': '{value}', expected bytes >= 64"))?,
                other => return Err(format!("unknown field '{other}' (known: {IGTL_KEYS})")),
            }
        }
        Ok(o)
    }
}

/// What the I/O thread counts (read by the session's owner, never by the haptic thread's logic).
#[derive(Default, Debug)]
pub struct IgtlCounters {
    pub poses: AtomicU64,
    pub forces_sent: AtomicU64,
    /// Malformed messages and NaN/non-rotation poses dropped.
    pub dropped: AtomicU64,
    /// Messages of other types or other device names skipped.
    pub skipped: AtomicU64,
    pub reconnects: AtomicU64,
    /// Links dropped for silence longer than `silence` ms (the rest broke or lied).
    pub silences: AtomicU64,
}

struct Link {
    connected: AtomicBool,
    /// The peer closed the connection in order: the session ends.
    closed: AtomicBool,
    stop: AtomicBool,
    /// Set by the haptic thread's first poll: the I/O thread reads nothing before, so poses sent
    /// while a session starts wait in the socket instead of being answered with no force at all.
    ready: AtomicBool,
    /// Bumped on every new connection, so the haptic thread forgets the old link's pose.
    generation: AtomicU64,
    counters: IgtlCounters,
}

#[derive(Clone, Copy)]
struct PoseMsg {
    pose: DAffine3,
    generation: u64,
}

const POSE_QUEUE: usize = 256;
const FORCE_QUEUE: usize = 256;

/// The haptic thread's end of an OpenIGTLink bridge.
pub struct IgtlDevice {
    poses: rtrb::Consumer<PoseMsg>,
    forces: rtrb::Producer<[f64; 6]>,
    link: Arc<Link>,
    options: IgtlOptions,
    name: String,
    pose: Option<DAffine3>,
    generation: u64,
    last_pose_t: f64,
    new_pose: bool,
    last_pushed_zero: bool,
    io: Option<JoinHandle<()>>,
}

impl IgtlDevice {
    /// Connects (retrying for `connect_ms`) and starts the I/O thread; errors name the address.
    pub fn connect(options: IgtlOptions) -> Result<IgtlDevice> {
        let addr = format!("{}:{}", options.host, options.port);
        let what = format!("OpenIGTLink peer {addr}");
        let deadline = Instant::now() + Duration::from_secs_f64(options.connect_ms * 1e-3);
        let stream = loop {
            match open_stream(&addr) {
                Ok(s) => break s,
                Err(e) if Instant::now() >= deadline => {
                    return Err(Error::Invalid { what, message: format!("cannot connect: {e}") });
                }
                Err(_) => std::thread::sleep(Duration::from_millis(50)),
            }
        };
        let (pose_tx, poses) = rtrb::RingBuffer::new(POSE_QUEUE);
        let (forces, force_rx) = rtrb::RingBuffer::new(FORCE_QUEUE);
        let link = Arc::new(Link {
            connected: AtomicBool::new(true),
            closed: AtomicBool::new(false),
            stop: AtomicBool::new(false),
            ready: AtomicBool::new(false),
            generation: AtomicU64::new(1),
            counters: IgtlCounters::default(),
        });
        let io = {
            let link = link.clone();
            let options = options.clone();
            std::thread::Builder::new()
                .name("dentsim-igtl".into())
                .spawn(move || {
                    raise_priority();
                    io_loop(stream, addr, options, link, pose_tx, force_rx)
                })
                .map_err(|e| Error::Invalid { what: what.clone(), message: format!("cannot start its thread: {e}") })?
        };
        Ok(IgtlDevice {
            poses,
            forces,
            link,
            name: format!("igtl://{}:{}", options.host, options.port),
            options,
            pose: None,
            generation: 1,
            last_pose_t: f64::NEG_INFINITY,
            new_pose: false,
            last_pushed_zero: true,
            io: Some(io),
        })
    }

    pub fn counters(&self) -> &IgtlCounters {
        &self.link.counters
    }

    /// A handle to the counters that outlives the device moving into a session.
    pub fn counters_handle(&self) -> IgtlCountersHandle {
        IgtlCountersHandle(self.link.clone())
    }
}

/// Shared view of a bridge's counters.
#[derive(Clone)]
pub struct IgtlCountersHandle(Arc<Link>);

impl IgtlCountersHandle {
    pub fn get(&self) -> &IgtlCounters {
        &self.0.counters
    }
}

/// The I/O thread sleeps in `read` and answers at once: as a SCHED_FIFO thread (below the
/// haptic thread's 50, above the logger's 30) where permitted, so a busy machine does not delay
/// the answer; else a raised normal priority, else as it is.
fn raise_priority() {
    use thread_priority::{
        set_thread_priority_and_policy, thread_native_id, RealtimeThreadSchedulePolicy, ThreadPriority, ThreadPriorityValue,
        ThreadSchedulePolicy,
    };
    let fifo = ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo);
    if let Ok(v) = ThreadPriorityValue::try_from(40u8) {
        if set_thread_priority_and_policy(thread_native_id(), ThreadPriority::Crossplatform(v), fifo).is_ok() {
            return;
        }
    }
    if let Ok(v) = ThreadPriorityValue::try_from(15u8) {
        let _ = thread_priority::set_current_thread_priority(ThreadPriority::Crossplatform(v));
    }
}

fn open_stream(addr: &str) -> std::io::Result<TcpStream> {
    let sock = addr.to_socket_addrs()?.next().ok_or_else(|| std::io::Error::new(ErrorKind::NotFound, "no address"))?;
    let s = TcpStream::connect_timeout(&sock, Duration::from_millis(500))?;
    // Poses and forces are single small messages: waiting to batch them would add 40 ms.
    s.set_nodelay(true)?;
    Ok(s)
}

impl Device for IgtlDevice {
    fn poll(&mut self, t: f64) -> std::result::Result<DeviceState, Fault> {
        if !self.link.ready.load(Ordering::Relaxed) {
            self.link.ready.store(true, Ordering::Release);
        }
        self.new_pose = false;
        while let Ok(m) = self.poses.pop() {
            if m.generation != self.generation {
                self.generation = m.generation;
            }
            self.pose = Some(m.pose);
            self.last_pose_t = t;
            self.new_pose = true;
        }
        let generation = self.link.generation.load(Ordering::Acquire);
        if generation != self.generation {
            // A new connection: the old link's pose is not the hand's any more.
            self.generation = generation;
            self.pose = None;
        }
        let live = self.link.connected.load(Ordering::Acquire) && t - self.last_pose_t <= self.options.stall_ms * 1e-3;
        match self.pose {
            Some(pose) if live => Ok(DeviceState { pose, buttons: if self.options.pedal { BUTTON_CUT } else { 0 }, rpm: DEFAULT_RPM }),
            _ => Err(Fault::Disconnected),
        }
    }

    /// One force per pose received (the I/O thread answers the next pose with it), and a zero
    /// at once when the force drops to zero (a fault), so a stalled link resumes at zero.
    fn send_force(&mut self, force: DVec3, torque: DVec3) {
        let zero = force == DVec3::ZERO && torque == DVec3::ZERO;
        if self.new_pose || (zero && !self.last_pushed_zero) {
            let v = [force.x, force.y, force.z, torque.x, torque.y, torque.z];
            if self.forces.push(v).is_ok() {
                self.last_pushed_zero = zero;
            }
            self.new_pose = false;
        }
    }

    fn finished(&self, _t: f64) -> bool {
        self.link.closed.load(Ordering::Acquire) || STOP_ALL.load(Ordering::Acquire)
    }

    fn name(&self) -> &str {
        &self.name
    }
}

impl Drop for IgtlDevice {
    fn drop(&mut self) {
        self.link.stop.store(true, Ordering::Release);
        if let Some(h) = self.io.take() {
            let _ = h.join();
        }
    }
}

/// How long one blocking read waits before the I/O thread looks at its flags again.
const READ_SLICE: Duration = Duration::from_millis(20);

enum Ended {
    /// End of stream from the peer: the session is over.
    Closed,
    /// Broken, silent or lying: reconnect.
    Lost,
    Stopped,
}

fn io_loop(
    first: TcpStream,
    addr: String,
    options: IgtlOptions,
    link: Arc<Link>,
    mut poses: rtrb::Producer<PoseMsg>,
    mut forces: rtrb::Consumer<[f64; 6]>,
) {
    let mut stream = Some(first);
    let mut generation = 1;
    loop {
        if let Some(s) = stream.take() {
            link.connected.store(true, Ordering::Release);
            let ended = serve(s, &options, &link, generation, &mut poses, &mut forces);
            link.connected.store(false, Ordering::Release);
            match ended {
                Ended::Closed => {
                    link.closed.store(true, Ordering::Release);
                    return;
                }
                Ended::Stopped => return,
                Ended::Lost => {}
            }
        }
        if link.stop.load(Ordering::Acquire) || STOP_ALL.load(Ordering::Acquire) {
            return;
        }
        std::thread::sleep(Duration::from_millis(100));
        if let Ok(s) = open_stream(&addr) {
            generation += 1;
            link.generation.store(generation, Ordering::Release);
            link.counters.reconnects.fetch_add(1, Ordering::Relaxed);
            stream = Some(s);
        }
    }
}

/// Bodies of the types read are small; larger ones of those types are malformed.
const POSE_BODY_MAX: usize = 64 << 10;

fn serve(
    mut s: TcpStream,
    options: &IgtlOptions,
    link: &Link,
    generation: u64,
    poses: &mut rtrb::Producer<PoseMsg>,
    forces: &mut rtrb::Consumer<[f64; 6]>,
) -> Ended {
    if s.set_read_timeout(Some(READ_SLICE)).is_err() {
        return Ended::Lost;
    }
    while !link.ready.load(Ordering::Acquire) {
        if link.stop.load(Ordering::Acquire) || STOP_ALL.load(Ordering::Acquire) {
            return Ended::Stopped;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    let silence = Duration::from_secs_f64(options.silence_ms * 1e-3);
    let mut last_byte = Instant::now();
    let mut header = [0u8; HEADER_SIZE];
    let mut body: Vec<u8> = Vec::with_capacity(1024);
    let mut latest = [0.0f64; 6];
    // Stale forces from the previous link are never sent: start at zero.
    while forces.pop().is_ok() {}
    let mut out = [0u8; SENSOR_MESSAGE_MAX];
    let mut message_id = 0u32;
    let c = &link.counters;
    // Reads exactly `buf.len()` bytes, tolerating read timeouts between pieces.
    let read_full = |s: &mut TcpStream, buf: &mut [u8], last_byte: &mut Instant| -> std::result::Result<(), Ended> {
        let mut got = 0;
        while got < buf.len() {
            if link.stop.load(Ordering::Acquire) || STOP_ALL.load(Ordering::Acquire) {
                return Err(Ended::Stopped);
            }
            match s.read(&mut buf[got..]) {
                Ok(0) => return Err(Ended::Closed),
                Ok(n) => {
                    got += n;
                    *last_byte = Instant::now();
                }
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted) => {
                    if last_byte.elapsed() > silence {
                        link.counters.silences.fetch_add(1, Ordering::Relaxed);
                        return Err(Ended::Lost);
                    }
                }
                Err(_) => return Err(Ended::Lost),
            }
        }
        Ok(())
    };
    loop {
        if let Err(e) = read_full(&mut s, &mut header, &mut last_byte) {
            return e;
        }
        let h = Header::parse(&header);
        if h.check_version().is_err() || h.body_size > options.max_body {
            // The stream cannot be trusted past a header like this.
            c.dropped.fetch_add(1, Ordering::Relaxed);
            return Ended::Lost;
        }
        let kind = h.type_str();
        let wanted = matches!(kind, "TRANSFORM" | "POSITION")
            && options.pose_name.as_deref().is_none_or(|n| n == h.device_str())
            && h.body_size as usize <= POSE_BODY_MAX;
        if !wanted {
            // Skip the body in slices without keeping it.
            let mut left = h.body_size as usize;
            let mut sink = [0u8; 4096];
            while left > 0 {
                let n = left.min(sink.len());
                if let Err(e) = read_full(&mut s, &mut sink[..n], &mut last_byte) {
                    return e;
                }
                left -= n;
            }
            if matches!(kind, "TRANSFORM" | "POSITION") && h.body_size as usize > POSE_BODY_MAX {
                c.dropped.fetch_add(1, Ordering::Relaxed);
            } else {
                c.skipped.fetch_add(1, Ordering::Relaxed);
            }
            continue;
        }
        body.resize(h.body_size as usize, 0);
        if let Err(e) = read_full(&mut s, &mut body, &mut last_byte) {
            return e;
        }
        let pose = codec::content(&h, &body).and_then(|content| match kind {
            "TRANSFORM" => codec::parse_transform(content),
            _ => codec::parse_position(content),
        });
        let pose: std::result::Result<DAffine3, Malformed> = pose;
        let Ok(pose) = pose else {
            c.dropped.fetch_add(1, Ordering::Relaxed);
            continue;
        };
        c.poses.fetch_add(1, Ordering::Relaxed);
        // The answer first (the peer waits on it), then the pose for the next tick.
        while let Ok(f) = forces.pop() {
            latest = f;
        }
        let n = codec::write_sensor(&mut out, h.version, &options.force_name, &latest, codec::timestamp_now(), message_id);
        message_id = message_id.wrapping_add(1);
        if s.write_all(&out[..n]).is_err() {
            return Ended::Lost;
        }
        c.forces_sent.fetch_add(1, Ordering::Relaxed);
        let _ = poses.push(PoseMsg { pose, generation });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn url_options_parse_and_name_bad_fields() {
        let o = IgtlOptions::parse("10.0.0.2:2000?pose=Stylus&force=F&pedal=1&stall=50").unwrap();
        assert_eq!((o.host.as_str(), o.port, o.pose_name.as_deref(), o.force_name.as_str(), o.pedal, o.stall_ms), ("10.0.0.2", 2000, Some("Stylus"), "F", true, 50.0));
        let d = IgtlOptions::parse("").unwrap();
        assert_eq!((d.host.as_str(), d.port), ("127.0.0.1", 18944));
        assert!(IgtlOptions::parse("h:0").unwrap_err().contains("port"));
        assert!(IgtlOptions::parse("h:1?pedal=2").unwrap_err().contains("'pedal'"));
        assert!(IgtlOptions::parse("h:1?stall=-1").unwrap_err().contains("'stall'"));
        assert!(IgtlOptions::parse("h:1?colour=1").unwrap_err().contains("unknown field 'colour'"));
    }
}
