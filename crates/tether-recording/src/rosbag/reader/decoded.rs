//! [`Decoded`]: a bag's messages of chosen topics decoded as one message type, those
//! that do not decode skipped and counted.

use std::io::{Read, Seek};
use std::marker::PhantomData;

use tether_msgs::RosMessage;

use super::{BadMessage, BagError, BagMessage, CutShort, Messages, SkippedRecord};
use crate::skips::Skips;

/// Messages of chosen topics decoded as `M`; see [`Bag::decoded`](super::Bag::decoded).
pub struct Decoded<'a, R, M> {
    messages: Messages<'a, R>,
    bad: Skips<BadMessage>,
    _message: PhantomData<fn() -> M>,
}

impl<'a, R: Read + Seek, M: RosMessage> Decoded<'a, R, M> {
    /// The messages of `messages` decoded as `M`.
    pub(super) fn new(messages: Messages<'a, R>) -> Self {
        Decoded {
            messages,
            bad: Skips::default(),
            _message: PhantomData,
        }
    }

    /// Messages that did not decode (the first hundred, with reasons).
    pub fn bad_messages(&self) -> &[BadMessage] {
        self.bad.kept()
    }

    /// Number of messages that did not decode, plus message records that could not be
    /// attributed to a connection.
    pub fn bad_count(&self) -> usize {
        self.bad.count() + self.messages.skipped_count()
    }

    /// Message records skipped before decoding (no known connection).
    pub fn skipped(&self) -> &[SkippedRecord] {
        self.messages.skipped()
    }

    /// Where the walk stopped at a cut in the file; see [`Messages::cut`].
    pub fn cut(&self) -> Option<&CutShort> {
        self.messages.cut()
    }
}

impl<R: Read + Seek, M: RosMessage> Iterator for Decoded<'_, R, M> {
    type Item = Result<BagMessage<M>, BagError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            let raw = match self.messages.next()? {
                Ok(raw) => raw,
                Err(e) => return Some(Err(e)),
            };
            match raw.decode::<M>() {
                Ok(message) => {
                    return Some(Ok(BagMessage {
                        connection: raw.connection,
                        time: raw.time,
                        at: raw.at,
                        message,
                    }));
                }
                Err(error) => {
                    self.bad.record(BadMessage {
                        topic: raw.connection.topic.clone(),
                        at: raw.at,
                        error,
                    });
                }
            }
        }
    }
}
