//! The service's gRPC codec: protobuf by prost, as `tonic_prost::ProstCodec`,
//! but a message is encoded into one contiguous buffer of its exact size and
//! decoded from one contiguous slice. An answer holds thousands of small
//! nested poses; writing and reading them field by field through tonic's
//! growable frame buffer cost more than the simulation step itself.

use std::marker::PhantomData;

use prost::Message;
use prost::bytes::{Buf, BufMut};
use tonic::Status;
use tonic::codec::{BufferSettings, Codec, DecodeBuf, Decoder, EncodeBuf, Encoder};

/// `application/grpc+proto` with whole-message buffers.
pub struct WholeMessageCodec<T, U>(PhantomData<(T, U)>);

impl<T, U> Default for WholeMessageCodec<T, U> {
    fn default() -> Self {
        WholeMessageCodec(PhantomData)
    }
}

impl<T, U> Codec for WholeMessageCodec<T, U>
where
    T: Message + Send + 'static,
    U: Message + Default + Send + 'static,
{
    type Encode = T;
    type Decode = U;
    type Encoder = WholeEncoder<T>;
    type Decoder = WholeDecoder<U>;

    fn encoder(&mut self) -> Self::Encoder {
        WholeEncoder::default()
    }

    fn decoder(&mut self) -> Self::Decoder {
        WholeDecoder(PhantomData)
    }
}

/// Frame buffers start this large, bytes: an answer of 200 actors with 2 s
/// forecasts is about 180 kB, and growing the buffer copies it each time.
const BUFFER_SIZE: usize = 256 << 10;

/// The buffers of every whole-message encoder and decoder.
pub fn whole_buffers() -> BufferSettings {
    BufferSettings::new(BUFFER_SIZE, BUFFER_SIZE)
}

pub struct WholeEncoder<T>(PhantomData<T>);

impl<T> Default for WholeEncoder<T> {
    fn default() -> Self {
        WholeEncoder(PhantomData)
    }
}

impl<T: Message> Encoder for WholeEncoder<T> {
    type Item = T;
    type Error = Status;

    fn encode(&mut self, item: T, buf: &mut EncodeBuf<'_>) -> Result<(), Status> {
        buf.put_slice(&item.encode_to_vec());
        Ok(())
    }

    fn buffer_settings(&self) -> BufferSettings {
        whole_buffers()
    }
}

pub struct WholeDecoder<U>(PhantomData<U>);

impl<U: Message + Default> Decoder for WholeDecoder<U> {
    type Item = U;
    type Error = Status;

    fn decode(&mut self, buf: &mut DecodeBuf<'_>) -> Result<Option<U>, Status> {
        let len = buf.remaining();
        let decoded = if buf.chunk().len() == len {
            let item = U::decode(buf.chunk());
            buf.advance(len);
            item
        } else {
            U::decode(buf.copy_to_bytes(len))
        };
        decoded
            .map(Some)
            .map_err(|e| Status::internal(format!("a message that is not valid protobuf: {e}")))
    }

    fn buffer_settings(&self) -> BufferSettings {
        whole_buffers()
    }
}
