//! What the admin knows of the cluster, kept current from the bus: the newest
//! clock and vehicle batch, light and crosswalk states, each service's status
//! and liveliness. Reads (status, vehicles, the live map) are answered from
//! here, so a REST request never waits on the bus for them.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::{Arc, RwLock};
use std::time::Instant;
use trafficmesh_protocol::topics;

use anyhow::Result;
use trafficmesh_bus::Bus;
use trafficmesh_protocol::wire::{
    Clock, CrosswalkOccupancy, IntersectionView, LightState, ServiceStatus, SessionObjects,
};
use zenoh::bytes::ZBytes;
use zenoh::sample::SampleKind;

use crate::metrics;

#[derive(Default)]
pub struct ViewState {
    pub clock: Option<Clock>,
    /// The last tick before the newest restart: an older clock still on
    /// its way is not news.
    restarted_after: Option<u64>,
    /// The newest vehicle batch as published (binary, see `vehicle_codec`).
    pub batch: Option<ZBytes>,
    /// Bumped on every batch, so the live map sends each one at most once.
    pub batch_version: u64,
    pub lights: BTreeMap<String, LightState>,
    pub occupancy: BTreeMap<String, CrosswalkOccupancy>,
    pub statuses: BTreeMap<String, (ServiceStatus, Instant)>,
    pub alive: BTreeSet<String>,
    /// Bumped on every light or crosswalk change, so the live map sends them only then.
    pub states_version: u64,
    /// The traffic service's sessions: each one's newest actors and when they came.
    pub sessions: BTreeMap<String, (SessionObjects, Instant)>,
    /// Bumped on every session answer, so the live map sends them only then.
    pub sessions_version: u64,
    /// The intersection service's newest view of its reservation intersections.
    pub intersections: Option<IntersectionView>,
    /// Bumped on every view, so the live map sends each one at most once.
    pub intersections_version: u64,
}

/// A session silent for this long is no longer drawn, seconds.
pub const SESSION_SILENCE: f64 = 5.0;

impl ViewState {
    /// The sessions heard from within [`SESSION_SILENCE`].
    pub fn live_sessions(&self) -> Vec<&SessionObjects> {
        self.sessions
            .values()
            .filter(|(_, at)| at.elapsed().as_secs_f64() < SESSION_SILENCE)
            .map(|(s, _)| s)
            .collect()
    }
}

#[derive(Default)]
pub struct ClusterView {
    state: RwLock<ViewState>,
}

impl ClusterView {
    pub fn read(&self) -> std::sync::RwLockReadGuard<'_, ViewState> {
        self.state.read().expect("view lock")
    }

    fn write(&self) -> std::sync::RwLockWriteGuard<'_, ViewState> {
        self.state.write().expect("view lock")
    }

    /// The stepper restarted after `tick`: the road is empty now, whatever
    /// clock of the old run comes in late.
    pub fn restarted(&self, tick: u64) {
        let mut v = self.write();
        v.restarted_after = Some(tick);
        if let Some(clock) = v.clock.as_mut() {
            clock.vehicles = 0;
        }
    }

    /// Subscribes to everything the view holds; the tasks run until the process ends.
    /// `groups` and `areas` are the map's counts, to know when catching up is done.
    pub async fn follow(
        self: &Arc<Self>,
        bus: Arc<Bus>,
        groups: usize,
        areas: usize,
    ) -> Result<()> {
        let keys = bus.keys().clone();

        let vehicles = bus.subscribe_ring(&keys.key(&topics::VEHICLES), 1).await?;
        let view = self.clone();
        tokio::spawn(async move {
            while let Ok(sample) = vehicles.recv_async().await {
                let mut v = view.write();
                v.batch = Some(sample.payload().clone());
                v.batch_version += 1;
            }
        });

        let clock = bus.subscribe_ring(&keys.key(&topics::CLOCK), 1).await?;
        let (view, b) = (self.clone(), bus.clone());
        tokio::spawn(async move {
            while let Ok(sample) = clock.recv_async().await {
                if let Some(c) = b.decode::<Clock>(&sample) {
                    let mut v = view.write();
                    if v.restarted_after.is_some_and(|t| c.tick <= t) {
                        continue;
                    }
                    v.restarted_after = None;
                    metrics::record_clock(&c);
                    v.clock = Some(c);
                }
            }
        });

        // Events only feed the counters; every batch counts, so no ring here.
        let events = bus.subscribe_to(&topics::EVENTS).await?;
        let b = bus.clone();
        tokio::spawn(async move {
            while let Some((_, batch)) = events.next(&b).await {
                metrics::record_events(&batch.events);
            }
        });

        let lights = bus.subscribe_to(&topics::LIGHT_STATE).await?;
        let (view, b) = (self.clone(), bus.clone());
        tokio::spawn(async move {
            while let Some((_, s)) = lights.next(&b).await {
                let mut v = view.write();
                v.lights.insert(s.group.clone(), s);
                v.states_version += 1;
            }
        });

        let occupancy = bus.subscribe_to(&topics::OCCUPANCY).await?;
        let (view, b) = (self.clone(), bus.clone());
        tokio::spawn(async move {
            while let Some((_, o)) = occupancy.next(&b).await {
                let mut v = view.write();
                v.occupancy.insert(o.area.clone(), o);
                v.states_version += 1;
            }
        });

        let sessions = bus.subscribe_to(&topics::TRAFFIC_SESSION).await?;
        let (view, b) = (self.clone(), bus.clone());
        tokio::spawn(async move {
            while let Some((name, s)) = sessions.next(&b).await {
                let mut v = view.write();
                v.sessions.insert(name, (s, Instant::now()));
                v.sessions_version += 1;
            }
        });

        let intersections = bus.subscribe_to(&topics::INTERSECTION_VIEW).await?;
        let (view, b) = (self.clone(), bus.clone());
        tokio::spawn(async move {
            while let Some(x) = intersections.latest(&b).await {
                let mut v = view.write();
                v.intersections = Some(x);
                v.intersections_version += 1;
            }
        });

        let statuses = bus.subscribe_to(&topics::STATUS).await?;
        let (view, b) = (self.clone(), bus.clone());
        tokio::spawn(async move {
            while let Some((_, s)) = statuses.next(&b).await {
                metrics::record_status(&s);
                view.write()
                    .statuses
                    .insert(s.service.clone(), (s, Instant::now()));
            }
        });

        // Liveliness with history: the tokens already there, then arrivals and departures.
        let alive = bus
            .session()
            .liveliness()
            .declare_subscriber(keys.key_all(&topics::ALIVE))
            .history(true)
            .await
            .map_err(|e| anyhow::anyhow!("liveliness subscription: {e}"))?;
        let view = self.clone();
        tokio::spawn(async move {
            while let Ok(sample) = alive.recv_async().await {
                let service =
                    trafficmesh_protocol::Keys::last_chunk(sample.key_expr().as_str()).to_string();
                let mut v = view.write();
                match sample.kind() {
                    SampleKind::Put => v.alive.insert(service),
                    SampleKind::Delete => v.alive.remove(&service),
                };
            }
        });

        // States published before the admin started (or before the services
        // were up): asked for until every group and area is known.
        let view = self.clone();
        tokio::spawn(async move {
            loop {
                view.catch_up(&bus).await;
                let known = {
                    let v = view.read();
                    v.lights.len() >= groups && v.occupancy.len() >= areas
                };
                if known {
                    break;
                }
                // A session just opened meets the other peers one by one.
                tokio::time::sleep(std::time::Duration::from_millis(200)).await;
            }
        });
        Ok(())
    }

    /// The current light and crosswalk states, by query.
    async fn catch_up(&self, bus: &Bus) {
        let keys = bus.keys();
        let timeout = std::time::Duration::from_secs(2);
        let lights = bus
            .get_each::<LightState>(&keys.key_all(&topics::LIGHT_STATE), timeout)
            .await;
        let occupancy = bus
            .get_each::<CrosswalkOccupancy>(&keys.key_all(&topics::OCCUPANCY), timeout)
            .await;
        let mut v = self.write();
        for s in lights.unwrap_or_default() {
            v.lights.entry(s.group.clone()).or_insert(s);
        }
        for o in occupancy.unwrap_or_default() {
            v.occupancy.entry(o.area.clone()).or_insert(o);
        }
        v.states_version += 1;
    }
}
