//! Both ends of a lockstep round: the asker (the stepper, or the crosswalks
//! service of its agent sources) collects every member's answer to one tick;
//! a member answers each tick once and repeats that answer if asked again
//! (the asker retries a round until its required members have answered).

use std::collections::BTreeMap;
use std::future::Future;
use std::time::Duration;

use serde::Serialize;
use serde::de::DeserializeOwned;
use trafficmesh_protocol::wire::LockstepTick;
use zenoh::query::{ConsolidationMode, QueryTarget};

use crate::{Bus, BusError};
use trafficmesh_protocol::Keys;

/// How long one round waits for a member; a slower one is asked again.
pub const ROUND_TIMEOUT: Duration = Duration::from_secs(5);

/// How long a round that missed a required member waits before it asks again.
const RETRY: Duration = Duration::from_millis(100);

impl Bus {
    /// Asks every queryable on `key` (a wildcard) for `tick` and returns each
    /// answer by the last chunk of the key it came from, in name order. An
    /// answer that does not decode is counted as a bad payload and left out.
    pub async fn lockstep_round<R: DeserializeOwned>(
        &self,
        key: &str,
        tick: &LockstepTick,
    ) -> Result<BTreeMap<String, R>, BusError> {
        let replies = self
            .session()
            .get(key.to_string())
            .payload(serde_json::to_vec(tick).expect("wire types serialise"))
            .encoding(zenoh::bytes::Encoding::APPLICATION_JSON)
            .target(QueryTarget::All)
            .consolidation(ConsolidationMode::None)
            .timeout(ROUND_TIMEOUT)
            .await?;
        let mut answers = BTreeMap::new();
        while let Ok(reply) = replies.recv_async().await {
            let Ok(sample) = reply.result() else {
                self.reject(key, "a lockstep member answered with an error");
                continue;
            };
            let from = sample.key_expr().as_str();
            match serde_json::from_slice::<R>(&sample.payload().to_bytes()) {
                Ok(answer) => {
                    answers.insert(Keys::last_chunk(from).to_string(), answer);
                }
                Err(e) => self.reject(from, &format!("malformed lockstep answer: {e}")),
            }
        }
        Ok(answers)
    }

    /// `lockstep_round` until every `required` member has answered; logs once
    /// whom the tick waits for. `keep_going` runs between attempts and ends
    /// the wait with `None` when it returns false.
    pub async fn lockstep_round_of<R: DeserializeOwned>(
        &self,
        key: &str,
        tick: &LockstepTick,
        required: &[String],
        mut keep_going: impl FnMut() -> bool,
    ) -> Option<BTreeMap<String, R>> {
        let mut waited = false;
        loop {
            let missing = match self.lockstep_round::<R>(key, tick).await {
                Ok(answers) => {
                    let missing: Vec<&str> = required
                        .iter()
                        .filter(|m| !answers.contains_key(*m))
                        .map(String::as_str)
                        .collect();
                    if missing.is_empty() {
                        if waited {
                            tracing::info!("lockstep: {key} answered tick {}", tick.tick);
                        }
                        return Some(answers);
                    }
                    missing.join(", ")
                }
                Err(e) => e.to_string(),
            };
            if !waited {
                tracing::warn!(
                    "lockstep: tick {} (t={:.2}) waits for {missing} on {key}",
                    tick.tick,
                    tick.time
                );
                waited = true;
            }
            if !keep_going() {
                return None;
            }
            tokio::time::sleep(RETRY).await;
        }
    }

    /// Serves `key` as a lockstep member: `answer` runs once per tick, in the
    /// order the ticks come; a tick asked again gets the same answer.
    pub async fn answer_ticks<R, F, Fut>(&self, key: &str, mut answer: F) -> Result<(), BusError>
    where
        R: Serialize,
        F: FnMut(LockstepTick) -> Fut,
        Fut: Future<Output = R>,
    {
        let queryable = self.queryable(key).await?;
        let mut last: Option<(u64, Vec<u8>)> = None;
        while let Ok(query) = queryable.recv_async().await {
            let Some(tick) = self.query_payload::<LockstepTick>(&query).await else {
                continue;
            };
            let bytes = match last.take() {
                Some((t, bytes)) if t == tick.tick => bytes,
                _ => serde_json::to_vec(&answer(tick.clone()).await).expect("wire types serialise"),
            };
            if let Err(e) = query
                .reply(key.to_string(), bytes.clone())
                .encoding(zenoh::bytes::Encoding::APPLICATION_JSON)
                .await
            {
                tracing::warn!("could not answer {key}: {e}");
            }
            last = Some((tick.tick, bytes));
        }
        Ok(())
    }
}
