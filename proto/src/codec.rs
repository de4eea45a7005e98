//! The services' codec: prost's, except that a message's encoder reserves
//! its encoded length first. Tonic's send buffer starts at 8 KiB and
//! prost writes into it a field at a time, so a 2 MiB image piece would
//! otherwise grow it by doubling, copying what it holds each time.

use prost::Message;
use std::marker::PhantomData;
use tonic::codec::{BufferSettings, Codec, EncodeBuf, Encoder};
use tonic::Status;
use tonic_prost::{ProstCodec, ProstDecoder};

/// Room a stream's receive buffer starts with. Tonic's 8 KiB is just
/// short of a tile result (8 KiB of sums and its header), so every result
/// grew the buffer again: with 10,000 workers connected, the coordinator's
/// time in malloc's heap growth halved with this room.
const DECODE_BUFFER: usize = 12 * 1024;
/// Tonic's default: bytes decoded before a stream yields to others.
const DECODE_YIELD: usize = 32 * 1024;

/// Prost encoding and decoding, with one reservation per message sent.
#[derive(Debug, Clone, Default)]
pub struct ReservingCodec<T, U>(PhantomData<(T, U)>);

impl<T, U> Codec for ReservingCodec<T, U>
where
    T: Message + Send + 'static,
    U: Message + Default + Send + 'static,
{
    type Encode = T;
    type Decode = U;
    type Encoder = ReservingEncoder<T>;
    type Decoder = ProstDecoder<U>;

    fn encoder(&mut self) -> Self::Encoder {
        ReservingEncoder(PhantomData)
    }

    fn decoder(&mut self) -> Self::Decoder {
        ProstCodec::<T, U>::raw_decoder(BufferSettings::new(DECODE_BUFFER, DECODE_YIELD))
    }
}

/// Encodes a message into room reserved for all of it.
#[derive(Debug, Clone, Default)]
pub struct ReservingEncoder<T>(PhantomData<T>);

impl<T: Message> Encoder for ReservingEncoder<T> {
    type Item = T;
    type Error = Status;

    fn encode(&mut self, item: T, buf: &mut EncodeBuf<'_>) -> Result<(), Status> {
        buf.reserve(item.encoded_len());
        item.encode(buf).map_err(|e| Status::internal(format!("encoding a message: {e}")))
    }

    fn buffer_settings(&self) -> BufferSettings {
        BufferSettings::default()
    }
}
