//! One frame on the in-process loopback simulator, through the real byte stream (hello,
//! upload, render), for tests and `gridrt bench skip`.

use std::time::Duration;

use gridrt_loopback::SimConfig;
use gridrt_shared::msg::RenderRequest;

use crate::scene_image::PreparedScene;
use crate::session::{RenderedFrame, Session, SessionConfig, SessionError};

/// A simulated board with a scene loaded; renders frames on request.
pub struct SimBoard {
    session: Session<gridrt_loopback::SimPort>,
}

impl SimBoard {
    /// Starts a simulated board and uploads `prepared`.
    pub fn new(config: SimConfig, prepared: &PreparedScene) -> Result<Self, SessionError> {
        let mut port = gridrt_loopback::spawn(config);
        port.set_timeout(Duration::from_millis(50));
        let mut session = Session::new(port, SessionConfig::new("sim").render_timeout(Duration::from_secs(600)));
        let mut quiet = |_| {};
        session.hello(&mut quiet)?;
        session.upload_scene(&prepared.image, &mut quiet)?;
        Ok(Self { session })
    }

    /// Renders one frame.
    pub fn render(&mut self, req: &RenderRequest) -> Result<RenderedFrame, SessionError> {
        self.session.render(req, &mut |_| {})
    }
}
