//! The declared keys of `trafficmesh_protocol::topics` used by their types:
//! a subscription that yields decoded samples of its topic's type, and a
//! queryable that answers its call's requests with its handler. Bad
//! payloads are logged, counted in the status and answered with an error,
//! as everywhere on the bus.

use std::future::Future;

use serde::Serialize;
use serde::de::DeserializeOwned;
use trafficmesh_protocol::Keys;
use trafficmesh_protocol::topics::{Call, Topic};
use zenoh::handlers::FifoChannelHandler;
use zenoh::sample::Sample;

use crate::{Bus, BusError};

/// A subscription to a declared topic: samples decoded as its type.
pub struct Subscription<T> {
    subscriber: zenoh::pubsub::Subscriber<FifoChannelHandler<Sample>>,
    topic: Topic<T>,
}

impl<T: DeserializeOwned> Subscription<T> {
    /// The next sample that decodes, with the named chunk of its key (a
    /// source's or simulator's name); None once the session closes.
    pub async fn next(&self, bus: &Bus) -> Option<(String, T)> {
        loop {
            let sample = self.subscriber.recv_async().await.ok()?;
            if let Some(value) = bus.decode::<T>(&sample) {
                let key = sample.key_expr().as_str();
                return Some((Keys::name_in(&self.topic, key).to_string(), value));
            }
        }
    }

    /// The newest sample that decodes, skipping those already queued (a
    /// reader that only needs the latest state, such as the clock's).
    pub async fn latest(&self, bus: &Bus) -> Option<T> {
        bus.next_latest::<T>(&self.subscriber).await
    }
}

impl Bus {
    /// Subscribes to a declared topic (every name of a named one).
    pub async fn subscribe_to<T>(&self, topic: &Topic<T>) -> Result<Subscription<T>, BusError> {
        Ok(Subscription {
            subscriber: self.subscribe(&self.keys().key_all(topic)).await?,
            topic: *topic,
        })
    }

    /// Answers every query on `call`'s key, one at a time, with `handler`'s
    /// answer; its `Err(reason)` is counted as a bad payload and answered as
    /// an error. Returns when the session closes.
    pub async fn serve<Req, Resp, F, Fut>(
        &self,
        call: &Call<Req, Resp>,
        handler: F,
    ) -> Result<(), BusError>
    where
        Req: DeserializeOwned,
        Resp: Serialize,
        F: FnMut(Req) -> Fut,
        Fut: Future<Output = Result<Resp, String>>,
    {
        self.declare_call(call).await?.serve(self, handler).await;
        Ok(())
    }

    /// Declares `call`'s queryable now, to be served later (by a task of
    /// its own) with [`Served::serve`]: queries that come in between wait.
    pub async fn declare_call<Req, Resp>(
        &self,
        call: &Call<Req, Resp>,
    ) -> Result<Served<Req, Resp>, BusError> {
        Ok(Served {
            queryable: self.queryable(&self.keys().key(call)).await?,
            types: std::marker::PhantomData,
        })
    }
}

/// A call's queryable, declared.
pub struct Served<Req, Resp> {
    queryable: zenoh::query::Queryable<FifoChannelHandler<zenoh::query::Query>>,
    types: std::marker::PhantomData<fn(Req) -> Resp>,
}

impl<Req: DeserializeOwned, Resp: Serialize> Served<Req, Resp> {
    /// Answers every query, one at a time, as [`Bus::serve`] does; returns
    /// when the session closes.
    pub async fn serve<F, Fut>(self, bus: &Bus, mut handler: F)
    where
        F: FnMut(Req) -> Fut,
        Fut: Future<Output = Result<Resp, String>>,
    {
        while let Ok(query) = self.queryable.recv_async().await {
            let Some(request) = bus.query_payload::<Req>(&query).await else {
                continue;
            };
            match handler(request).await {
                Ok(answer) => bus.reply(&query, &answer).await,
                Err(reason) => {
                    bus.reject(query.key_expr().as_str(), &reason);
                    bus.reply_error(&query, &reason).await;
                }
            }
        }
    }
}
