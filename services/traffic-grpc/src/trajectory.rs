//! `common.Trajectory` with an encoder of its own. An answer is mostly
//! trajectories (200 actors with 21 poses each); prost's derived encoder
//! works out the length of every nested pose again at each level above it,
//! and writes each field through its own buffer call. Here a pose whose
//! position and rotation are both present is written in one go, to the same
//! bytes prost writes (fields at their default left out); anything else, and
//! decoding, is prost's.

use prost::bytes::{Buf, BufMut};
use prost::encoding::{DecodeContext, WireType, message, skip_field};
use prost::{DecodeError, Message};

use crate::proto::common::PoseAtTime;

/// `repeated PoseAtTime poses = 1;`
#[derive(Clone, PartialEq, Debug, Default)]
pub struct Trajectory {
    pub poses: Vec<PoseAtTime>,
}

/// The most a whole pose takes as a field of a trajectory: its key and
/// length, the pose's key and length, the position's (three fixed32 fields
/// of five bytes), the rotation's (four), and the fixed64 timestamp. Every
/// length fits one byte.
const MAX_POSE: usize = 2 + 2 + (2 + 15) + (2 + 20) + 9;

/// A pose with both a position and a rotation: its fields.
struct WholePose {
    /// x, y, z.
    position: [f32; 3],
    /// w, x, y, z.
    rotation: [f32; 4],
    t_us: u64,
}

impl WholePose {
    fn of(p: &PoseAtTime) -> Option<Self> {
        let pose = p.pose.as_ref()?;
        let (v, q) = (pose.vec.as_ref()?, pose.quat.as_ref()?);
        Some(WholePose {
            position: [v.x, v.y, v.z],
            rotation: [q.w, q.x, q.y, q.z],
            t_us: p.timestamp_us,
        })
    }

    /// The `Pose` message's bytes: position and rotation, each with its key
    /// and length.
    fn pose_len(&self) -> usize {
        2 + floats_len(&self.position) + 2 + floats_len(&self.rotation)
    }

    /// The timestamp's bytes, none at its default.
    fn time_len(&self) -> usize {
        if self.t_us != 0 { 9 } else { 0 }
    }

    /// Its bytes as a field of a trajectory.
    fn len(&self) -> usize {
        2 + 2 + self.pose_len() + self.time_len()
    }

    /// Writes those bytes to `out` in one pass, each length filled in once
    /// what it counts is written; returns their count.
    fn write(&self, out: &mut [u8; MAX_POSE]) -> usize {
        out[0] = 0x0A;
        out[2] = 0x0A;
        let n = write_floats(out, 4, 0x0A, &self.position);
        let mut n = write_floats(out, n, 0x12, &self.rotation);
        out[3] = (n - 4) as u8;
        if self.t_us != 0 {
            out[n] = 0x11;
            out[n + 1..n + 9].copy_from_slice(&self.t_us.to_le_bytes());
            n += 9;
        }
        out[1] = (n - 2) as u8;
        n
    }
}

/// Writes the message of `floats` (fixed32 fields 1, 2, ... left out at
/// zero) as field `key` of its parent at `out[n..]`; returns the end.
fn write_floats(out: &mut [u8; MAX_POSE], n: usize, key: u8, floats: &[f32]) -> usize {
    out[n] = key;
    let start = n + 2;
    let mut end = start;
    for (field, x) in (1u8..).zip(floats) {
        if *x != 0.0 {
            out[end] = (field << 3) | 5;
            out[end + 1..end + 5].copy_from_slice(&x.to_le_bytes());
            end += 5;
        }
    }
    out[n + 1] = (end - start) as u8;
    end
}

/// Bytes of the fixed32 fields of `floats` that are not zero.
fn floats_len(floats: &[f32]) -> usize {
    5 * floats.iter().filter(|&&x| x != 0.0).count()
}

impl Message for Trajectory {
    fn encode_raw(&self, buf: &mut impl BufMut) {
        let mut bytes = [0u8; MAX_POSE];
        for p in &self.poses {
            match WholePose::of(p) {
                Some(whole) => {
                    let n = whole.write(&mut bytes);
                    buf.put_slice(&bytes[..n]);
                }
                None => message::encode(1, p, buf),
            }
        }
    }

    fn merge_field(
        &mut self,
        tag: u32,
        wire_type: WireType,
        buf: &mut impl Buf,
        ctx: DecodeContext,
    ) -> Result<(), DecodeError> {
        match tag {
            1 => message::merge_repeated(wire_type, &mut self.poses, buf, ctx),
            _ => skip_field(wire_type, tag, buf, ctx),
        }
    }

    fn encoded_len(&self) -> usize {
        self.poses
            .iter()
            .map(|p| match WholePose::of(p) {
                Some(whole) => whole.len(),
                None => message::encoded_len(1, p),
            })
            .sum()
    }

    fn clear(&mut self) {
        self.poses.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::common::{Pose, Quat, Vec3};

    /// The trajectory as prost derives it.
    #[derive(Clone, PartialEq, prost::Message)]
    struct Derived {
        #[prost(message, repeated, tag = "1")]
        poses: Vec<PoseAtTime>,
    }

    fn pose(t: u64, x: f32, w: f32) -> PoseAtTime {
        PoseAtTime {
            pose: Some(Pose {
                vec: Some(Vec3 {
                    x,
                    y: -2.5,
                    z: 0.75,
                }),
                quat: Some(Quat {
                    w,
                    x: 0.1,
                    y: -0.2,
                    z: 0.3,
                }),
            }),
            timestamp_us: t,
        }
    }

    #[test]
    fn whole_poses_are_written_as_prost_writes_them() {
        let poses = vec![
            pose(1, 3.0, 0.9),
            pose(u64::MAX, -1e30, 1.0),
            pose(0, 0.0, 0.0),
        ];
        let ours = Trajectory {
            poses: poses.clone(),
        };
        let bytes = ours.encode_to_vec();
        assert_eq!(bytes, Derived { poses }.encode_to_vec());
        assert_eq!(bytes.len(), ours.encoded_len());
        assert_eq!(
            ours.poses[..1]
                .iter()
                .map(|p| message::encoded_len(1, p))
                .sum::<usize>(),
            MAX_POSE
        );
    }

    #[test]
    fn partial_poses_are_prosts_and_come_back_as_they_were() {
        let mut partial = pose(5, 1.0, 1.0);
        partial.pose.as_mut().unwrap().quat = None;
        let poses = vec![
            pose(0, 0.0, 0.0),
            partial,
            PoseAtTime {
                pose: None,
                timestamp_us: 9,
            },
        ];
        let ours = Trajectory {
            poses: poses.clone(),
        };
        let bytes = ours.encode_to_vec();
        assert_eq!(bytes.len(), ours.encoded_len());
        assert_eq!(bytes, Derived { poses }.encode_to_vec());
        assert_eq!(Trajectory::decode(bytes.as_slice()).unwrap(), ours);
    }
}
