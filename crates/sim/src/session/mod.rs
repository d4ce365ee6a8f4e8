//! Sessions: the haptic, mesher and logger threads, the binary log, the live display, replay,
//! a session's outputs in a folder, the force plot.
pub mod guidance;
pub mod live;
pub mod log;
pub mod outputs;
pub mod plot;
pub mod replay;
pub mod threads;

pub use guidance::{GuidanceEvent, GuidanceKind, GuidanceReport, GuidanceTracker};
pub use live::{LiveRequest, LiveSession, LiveState};
pub use log::{SessionLog, TickRecord};
pub use outputs::{replay_to_dir, replay_to_dir_with, run_session_to_dir, run_session_to_dir_with, SessionRequest};
pub use replay::{replay, ReplayOutcome};
pub use threads::{idle_loop_starts_s, run_session, Session, SessionOptions, SessionOutcome, DEFAULT_MESHER_HZ, QUEUE_CHANGES};
