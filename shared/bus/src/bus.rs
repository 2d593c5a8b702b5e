//! An open session with the cluster's keys, typed put/subscribe/query helpers
//! and the bad-payload counters every service reports in its status.

use std::sync::Arc;
use std::time::Duration;

use serde::Serialize;
use serde::de::DeserializeOwned;
use zenoh::Session;
use zenoh::bytes::Encoding;
use zenoh::liveliness::LivelinessToken;
use zenoh::qos::CongestionControl;
use zenoh::query::Query;
use zenoh::sample::Sample;

use crate::{BadPayloads, BusArgs, BusError, Role};
use trafficmesh_protocol::Keys;
use trafficmesh_protocol::topics::{self, Call, Topic};

/// Which delivery a publisher gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lane {
    /// Reliable and blocking when congested: commands, answers, states, events.
    Reliable,
    /// Dropped when congested, sent without batching delay: per-tick telemetry.
    Telemetry,
}

pub struct Bus {
    session: Session,
    keys: Keys,
    service: String,
    bad: Arc<BadPayloads>,
    _alive: Option<LivelinessToken>,
}

impl Bus {
    /// Opens a session (a client command's; services use `open_service`).
    pub async fn open(args: &BusArgs, role: Role, service: &str) -> Result<Bus, BusError> {
        let keys = args.keys()?;
        let config = args.zenoh_config(role)?;
        let session = zenoh::open(config).await?;
        Ok(Bus {
            session,
            keys,
            service: service.to_string(),
            bad: Arc::new(BadPayloads::default()),
            _alive: None,
        })
    }

    /// Opens the session of a service and declares its liveliness token
    /// `<cluster>/alive/<service>`, which tells the cluster it is up.
    pub async fn open_service(args: &BusArgs, role: Role, service: &str) -> Result<Bus, BusError> {
        let mut bus = Bus::open(args, role, service).await?;
        let token = bus
            .session
            .liveliness()
            .declare_token(bus.keys.key_at(&topics::ALIVE, service))
            .await?;
        bus._alive = Some(token);
        Ok(bus)
    }

    pub fn session(&self) -> &Session {
        &self.session
    }
    pub fn keys(&self) -> &Keys {
        &self.keys
    }
    pub fn service(&self) -> &str {
        &self.service
    }
    pub fn bad_payloads(&self) -> &Arc<BadPayloads> {
        &self.bad
    }

    /// Waits until at least one other Zenoh node is connected, or `timeout`.
    pub async fn wait_for_peer(&self, timeout: Duration) -> bool {
        let deadline = tokio::time::Instant::now() + timeout;
        loop {
            let info = self.session.info();
            if info.peers_zid().await.next().is_some() || info.routers_zid().await.next().is_some()
            {
                return true;
            }
            if tokio::time::Instant::now() >= deadline {
                return false;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }

    pub async fn publisher(&self, key: String, lane: Lane) -> Result<Publisher, BusError> {
        self.publisher_encoded(key, lane, Encoding::APPLICATION_JSON)
            .await
    }

    /// A publisher of binary payloads (put with `put_bytes`), tagged
    /// `application/octet-stream;<schema>` so a reader can tell the layout.
    pub async fn binary_publisher(
        &self,
        key: String,
        lane: Lane,
        schema: &str,
    ) -> Result<Publisher, BusError> {
        let encoding = Encoding::APPLICATION_OCTET_STREAM.with_schema(schema);
        self.publisher_encoded(key, lane, encoding).await
    }

    async fn publisher_encoded(
        &self,
        key: String,
        lane: Lane,
        encoding: Encoding,
    ) -> Result<Publisher, BusError> {
        let builder = self
            .session
            .declare_publisher(key.clone())
            .encoding(encoding);
        let publisher = match lane {
            Lane::Reliable => builder.congestion_control(CongestionControl::Block),
            Lane::Telemetry => builder
                .congestion_control(CongestionControl::Drop)
                .express(true),
        }
        .await?;
        Ok(Publisher { key, publisher })
    }

    /// A reliable one-off put.
    pub async fn put<T: Serialize>(&self, key: &str, value: &T) -> Result<(), BusError> {
        let bytes = serde_json::to_vec(value).expect("wire types serialise");
        self.session
            .put(key, bytes)
            .encoding(Encoding::APPLICATION_JSON)
            .congestion_control(CongestionControl::Block)
            .await?;
        Ok(())
    }

    /// A sample of a declared key's own type on that key.
    pub async fn publish<T: Serialize>(&self, topic: &Topic<T>, value: &T) -> Result<(), BusError> {
        self.put(&self.keys().key(topic), value).await
    }

    /// A sample of a declared key's own type on that key, its named chunk `name`.
    pub async fn publish_at<T: Serialize>(
        &self,
        topic: &Topic<T>,
        name: &str,
        value: &T,
    ) -> Result<(), BusError> {
        self.put(&self.keys().key_at(topic, name), value).await
    }

    pub async fn subscribe(
        &self,
        key: &str,
    ) -> Result<zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<Sample>>, BusError>
    {
        Ok(self.session.declare_subscriber(key.to_string()).await?)
    }

    /// A subscription that keeps only the newest `capacity` samples and never
    /// holds up the session when its reader falls behind.
    pub async fn subscribe_ring(
        &self,
        key: &str,
        capacity: usize,
    ) -> Result<zenoh::pubsub::Subscriber<zenoh::handlers::RingChannelHandler<Sample>>, BusError>
    {
        Ok(self
            .session
            .declare_subscriber(key.to_string())
            .with(zenoh::handlers::RingChannel::new(capacity))
            .await?)
    }

    pub async fn queryable(
        &self,
        key: &str,
    ) -> Result<zenoh::query::Queryable<zenoh::handlers::FifoChannelHandler<Query>>, BusError> {
        Ok(self.session.declare_queryable(key.to_string()).await?)
    }

    /// Decodes a sample, or logs it with its key, counts it and returns None.
    pub fn decode<T: DeserializeOwned>(&self, sample: &Sample) -> Option<T> {
        let key = sample.key_expr().as_str();
        match serde_json::from_slice::<T>(&sample.payload().to_bytes()) {
            Ok(v) => Some(v),
            Err(e) => {
                self.reject(key, &format!("malformed JSON: {e}"));
                None
            }
        }
    }

    /// Counts a payload that cannot be used, and logs why (at most once
    /// every few seconds per key).
    pub fn reject(&self, key: &str, reason: &str) {
        self.bad.count(key, reason);
    }

    /// A query's JSON payload; a bad one is answered with an error, counted and None.
    pub async fn query_payload<T: DeserializeOwned>(&self, query: &Query) -> Option<T> {
        let key = query.key_expr().as_str().to_string();
        let result = match query.payload() {
            None => Err("missing payload".to_string()),
            Some(p) => serde_json::from_slice::<T>(&p.to_bytes())
                .map_err(|e| format!("malformed JSON: {e}")),
        };
        match result {
            Ok(v) => Some(v),
            Err(reason) => {
                self.reject(&key, &reason);
                self.reply_error(query, &reason).await;
                None
            }
        }
    }

    pub async fn reply<T: Serialize>(&self, query: &Query, value: &T) {
        self.reply_at(query, query.key_expr().as_str(), value).await
    }

    pub async fn reply_text(&self, query: &Query, text: String, encoding: Encoding) {
        if let Err(e) = query
            .reply(query.key_expr().clone(), text)
            .encoding(encoding)
            .await
        {
            tracing::warn!("could not answer {}: {e}", query.key_expr());
        }
    }

    pub async fn reply_error(&self, query: &Query, message: &str) {
        self.reply_problems(query, message, &[]).await
    }

    /// An error answer `{"error": message, "problems": [...]}` (the list only
    /// when there is one), e.g. every problem of a refused spawn config.
    pub async fn reply_problems(&self, query: &Query, message: &str, problems: &[String]) {
        let mut body = serde_json::json!({ "error": message });
        if !problems.is_empty() {
            body["problems"] = serde_json::json!(problems);
        }
        if let Err(e) = query
            .reply_err(serde_json::to_vec(&body).expect("json"))
            .encoding(Encoding::APPLICATION_JSON)
            .await
        {
            tracing::warn!("could not answer {}: {e}", query.key_expr());
        }
    }

    /// Sends a query and returns the raw payload of the first answer.
    pub async fn get_raw<Q: Serialize>(
        &self,
        key: &str,
        payload: Option<&Q>,
        timeout: Duration,
    ) -> Result<Vec<u8>, BusError> {
        let mut answers = self.get_all_raw(key, payload, timeout).await?;
        if answers.is_empty() {
            return Err(BusError::NoAnswer {
                key: key.to_string(),
                timeout_ms: timeout.as_millis(),
            });
        }
        answers.swap_remove(0)
    }

    /// Sends a query and collects every answer (errors as `BusError::Remote`).
    pub async fn get_all_raw<Q: Serialize>(
        &self,
        key: &str,
        payload: Option<&Q>,
        timeout: Duration,
    ) -> Result<Vec<Result<Vec<u8>, BusError>>, BusError> {
        // Every queryable, each reply as it comes: with Zenoh's defaults a
        // wildcard query's replies wait for the slowest one, and those
        // still held when the timeout strikes are lost.
        // Dropped, not held, where a link stops draining: a query to a host
        // cut off would otherwise hold a router thread until that host's
        // session is closed, and enough of them stall the router for every
        // host (eclipse-zenoh/zenoh#1876). A query lost so is a timeout the
        // caller already handles.
        let mut get = self
            .session
            .get(key.to_string())
            .target(zenoh::query::QueryTarget::All)
            .consolidation(zenoh::query::ConsolidationMode::None)
            .congestion_control(CongestionControl::Drop)
            .timeout(timeout);
        if let Some(p) = payload {
            get = get
                .payload(serde_json::to_vec(p).expect("wire types serialise"))
                .encoding(Encoding::APPLICATION_JSON);
        }
        let replies = get.await?;
        let mut answers = Vec::new();
        while let Ok(reply) = replies.recv_async().await {
            answers.push(match reply.result() {
                Ok(sample) => Ok(sample.payload().to_bytes().into_owned()),
                Err(err) => {
                    let raw = err.payload().to_bytes();
                    let body = serde_json::from_slice::<serde_json::Value>(&raw).ok();
                    let message = body
                        .as_ref()
                        .and_then(|v| v.get("error")?.as_str().map(String::from))
                        .unwrap_or_else(|| String::from_utf8_lossy(&raw).into_owned());
                    let problems = body
                        .as_ref()
                        .and_then(|v| v.get("problems")?.as_array().cloned())
                        .unwrap_or_default()
                        .into_iter()
                        .filter_map(|p| p.as_str().map(String::from))
                        .collect();
                    Err(BusError::Remote {
                        key: key.to_string(),
                        message,
                        problems,
                    })
                }
            });
        }
        Ok(answers)
    }

    /// A query with a typed answer.
    pub async fn get<Q: Serialize, R: DeserializeOwned>(
        &self,
        key: &str,
        payload: Option<&Q>,
        timeout: Duration,
    ) -> Result<R, BusError> {
        let raw = self.get_raw(key, payload, timeout).await?;
        serde_json::from_slice(&raw).map_err(|e| BusError::BadAnswer {
            key: key.to_string(),
            what: std::any::type_name::<R>(),
            reason: e.to_string(),
        })
    }

    /// A declared query: the request its declaration takes, the answer it
    /// gives, on the declared key.
    pub async fn call<Req: Serialize, Resp: DeserializeOwned>(
        &self,
        call: &Call<Req, Resp>,
        request: &Req,
        timeout: Duration,
    ) -> Result<Resp, BusError> {
        self.get(&self.keys().key(call), Some(request), timeout)
            .await
    }

    /// Every typed answer to a query on a key expression with wildcards.
    pub async fn get_each<R: DeserializeOwned>(
        &self,
        key: &str,
        timeout: Duration,
    ) -> Result<Vec<R>, BusError> {
        let answers = self.get_all_raw::<()>(key, None, timeout).await?;
        let mut out = Vec::new();
        for a in answers.into_iter().flatten() {
            match serde_json::from_slice(&a) {
                Ok(v) => out.push(v),
                Err(e) => self.reject(key, &format!("answer is not valid JSON: {e}")),
            }
        }
        Ok(out)
    }
}

/// A declared publisher of one key (JSON unless declared otherwise).
pub struct Publisher {
    key: String,
    publisher: zenoh::pubsub::Publisher<'static>,
}

impl Publisher {
    pub fn key(&self) -> &str {
        &self.key
    }

    pub async fn put<T: Serialize>(&self, value: &T) -> Result<(), BusError> {
        self.put_bytes(serde_json::to_vec(value).expect("wire types serialise"))
            .await
    }

    /// Bytes already encoded in the publisher's encoding.
    pub async fn put_bytes(&self, bytes: Vec<u8>) -> Result<(), BusError> {
        self.publisher.put(bytes).await?;
        Ok(())
    }

    /// Whether any subscriber matches (puts without one are silent no-ops).
    pub async fn has_subscribers(&self) -> bool {
        self.publisher
            .matching_status()
            .await
            .map(|m| m.matching())
            .unwrap_or(false)
    }
}

impl Bus {
    /// The newest decodable sample of a subscription, skipping any that queued
    /// up meanwhile (for the clock: only the latest time matters).
    pub async fn next_latest<T: DeserializeOwned>(
        &self,
        subscriber: &zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<Sample>>,
    ) -> Option<T> {
        loop {
            let mut sample = subscriber.recv_async().await.ok()?;
            while let Ok(Some(newer)) = subscriber.try_recv() {
                sample = newer;
            }
            if let Some(v) = self.decode::<T>(&sample) {
                return Some(v);
            }
        }
    }

    /// Answers a query on a wildcard key with one reply at `key`.
    pub async fn reply_at<T: Serialize>(&self, query: &Query, key: &str, value: &T) {
        let bytes = serde_json::to_vec(value).expect("wire types serialise");
        if let Err(e) = query
            .reply(key.to_string(), bytes)
            .encoding(Encoding::APPLICATION_JSON)
            .await
        {
            tracing::warn!("could not answer {}: {e}", query.key_expr());
        }
    }
}
