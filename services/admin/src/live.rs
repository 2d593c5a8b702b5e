//! The live map: the page and its script (embedded: nothing comes from the
//! network at run time), and a WebSocket that streams the newest vehicle batch
//! (binary, the bus layout unchanged), light/crosswalk states, the traffic
//! service's sessions and the reservation intersections' view (JSON text)
//! when they change.

use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Query, State};
use axum::http::header;
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use serde::Deserialize;

use crate::api::App;

const INDEX: &str = include_str!("../web/index.html");
const SCRIPT: &str = include_str!("../web/map.js");

pub fn pages() -> Router<Arc<App>> {
    Router::new()
        .route(
            "/",
            get(|| async { page(INDEX, "text/html; charset=utf-8") }),
        )
        .route(
            "/map.js",
            get(|| async { page(SCRIPT, "text/javascript; charset=utf-8") }),
        )
}

fn page(body: &'static str, content_type: &'static str) -> Response {
    ([(header::CONTENT_TYPE, content_type)], body).into_response()
}

#[derive(Deserialize)]
pub struct LiveOptions {
    /// Frames per second, 1 to 50 (default 10).
    hz: Option<f64>,
}

pub async fn socket(
    State(app): State<Arc<App>>,
    Query(o): Query<LiveOptions>,
    ws: WebSocketUpgrade,
) -> Response {
    let hz = o.hz.unwrap_or(10.0).clamp(1.0, 50.0);
    ws.on_upgrade(move |socket| stream(app, socket, Duration::from_secs_f64(1.0 / hz)))
}

/// Sends the newest batch every period (only when a new tick arrived), and the
/// states whenever their version moved. A slow browser gets fewer frames, never
/// a backlog: each send takes the newest data.
async fn stream(app: Arc<App>, mut socket: WebSocket, period: Duration) {
    let mut interval = tokio::time::interval(period);
    interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let (mut sent_batch, mut sent_states, mut sent_sessions) = (0u64, None::<u64>, 0u64);
    let mut sent_intersections = 0u64;
    loop {
        tokio::select! {
            _ = interval.tick() => {}
            incoming = socket.recv() => match incoming {
                Some(Ok(Message::Close(_))) | None | Some(Err(_)) => return,
                Some(Ok(_)) => continue,
            },
        }
        let (batch, states, sessions, intersections) = {
            let v = app.view.read();
            let intersections = v
                .intersections
                .as_ref()
                .filter(|_| v.intersections_version != sent_intersections)
                .map(|x| {
                    let text = serde_json::json!({"type": "intersections", "view": x});
                    (v.intersections_version, text.to_string())
                });
            // Sent again while any is live, so that one that falls silent goes away.
            let live = v.live_sessions();
            let sessions = (v.sessions_version != sent_sessions || !live.is_empty()).then(|| {
                let text = serde_json::json!({"type": "sessions", "sessions": live});
                (v.sessions_version, text.to_string())
            });
            let batch = v
                .batch
                .clone()
                .filter(|_| v.batch_version != sent_batch)
                .map(|b| (v.batch_version, b));
            let states = (Some(v.states_version) != sent_states).then(|| {
                let lights: serde_json::Map<String, serde_json::Value> = v
                    .lights
                    .iter()
                    .map(|(g, s)| (g.clone(), serde_json::to_value(s.color).unwrap_or_default()))
                    .collect();
                let crosswalks: serde_json::Map<String, serde_json::Value> = v
                    .occupancy
                    .iter()
                    .map(|(a, o)| (a.clone(), o.occupied.into()))
                    .collect();
                let text = serde_json::json!({"type": "states", "lights": lights, "crosswalks": crosswalks});
                (v.states_version, text.to_string())
            });
            (batch, states, sessions, intersections)
        };
        if let Some((version, text)) = intersections {
            if socket.send(Message::Text(text.into())).await.is_err() {
                return;
            }
            sent_intersections = version;
        }
        if let Some((version, text)) = sessions {
            if socket.send(Message::Text(text.into())).await.is_err() {
                return;
            }
            sent_sessions = version;
        }
        if let Some((version, text)) = states {
            if socket.send(Message::Text(text.into())).await.is_err() {
                return;
            }
            sent_states = Some(version);
        }
        if let Some((version, bytes)) = batch {
            if socket
                .send(Message::Binary(bytes.to_bytes().into_owned().into()))
                .await
                .is_err()
            {
                return;
            }
            sent_batch = version;
        }
    }
}
