//! Messages pieced together from bytes kept between ticks: only what
//! moves is encoded each tick (checked against prost's whole encoding in
//! debug builds).

use super::*;

/// A length-delimited field's size: key, length, body.
pub(super) fn field_len(tag: u32, inner: usize) -> usize {
    pe::key_len(tag) + pe::encoded_len_varint(inner as u64) + inner
}

/// An optional message field's size (0 when absent).
pub(super) fn opt_len<M: prost::Message>(tag: u32, m: &Option<M>) -> usize {
    m.as_ref().map_or(0, |m| pm::encoded_len(tag, m))
}

/// An optional message field (nothing when absent).
pub(super) fn opt<M: prost::Message>(tag: u32, m: &Option<M>, buf: &mut Vec<u8>) {
    if let Some(m) = m {
        pm::encode(tag, m, buf);
    }
}

/// A length-delimited field's key and length.
pub(super) fn head(tag: u32, inner: usize, buf: &mut Vec<u8>) {
    pe::encode_key(tag, pe::WireType::LengthDelimited, buf);
    pe::encode_varint(inner as u64, buf);
}

/// An actor's messages split at the fields a tick sets. prost writes a
/// message's fields in tag order, and the fields a tick sets come first
/// (timestamps, poses: tag 1) or between fixed ones, so each message is
/// a few pre-encoded runs of bytes with the tick's fields between them.
pub(super) struct Pieces {
    /// SceneEntity fields 2–6 (frame, id, metadata).
    entity: Vec<u8>,
    /// CubePrimitive fields 2–3 (size, colour).
    cube_tail: Vec<u8>,
    /// TextPrimitive fields 2–6 (billboard, font, colour, text).
    text_tail: Vec<u8>,
    /// FrameTransform fields 2–3 (parent and child frame).
    transform: Vec<u8>,
    /// MovingObject field 1 (id).
    object_id: Vec<u8>,
    /// BaseMoving field 1 (dimension).
    dimension: Vec<u8>,
    /// MovingObject fields 3– (type, classification, model).
    object_tail: Vec<u8>,
}

impl Pieces {
    /// The fixed parts of an actor's templates.
    pub(super) fn of(
        e: &fg::SceneEntity,
        tf: &fg::FrameTransform,
        o: &osi3::MovingObject,
    ) -> Pieces {
        let bytes = |m: &dyn Fn(&mut Vec<u8>)| {
            let mut b = Vec::new();
            m(&mut b);
            b
        };
        use prost::Message;
        Pieces {
            entity: fg::SceneEntity {
                timestamp: None,
                cubes: vec![],
                texts: vec![],
                ..e.clone()
            }
            .encode_to_vec(),
            cube_tail: bytes(&|b| {
                for c in e.cubes.iter().take(1) {
                    fg::CubePrimitive { pose: None, ..*c }.encode_raw(b);
                }
            }),
            text_tail: bytes(&|b| {
                for t in e.texts.iter().take(1) {
                    fg::TextPrimitive {
                        pose: None,
                        ..t.clone()
                    }
                    .encode_raw(b);
                }
            }),
            transform: fg::FrameTransform {
                timestamp: None,
                translation: None,
                rotation: None,
                ..tf.clone()
            }
            .encode_to_vec(),
            object_id: bytes(&|b| opt(1, &o.id, b)),
            dimension: bytes(&|b| opt(1, &o.base.as_ref().and_then(|b| b.dimension), b)),
            object_tail: osi3::MovingObject {
                id: None,
                base: None,
                ..o.clone()
            }
            .encode_to_vec(),
        }
    }

    /// `e` (this actor's entity with the tick's timestamp and poses) as a
    /// SceneUpdate `entities` field. Only its first cube and text are
    /// written: the templates have one of each.
    pub(super) fn entity(&self, e: &fg::SceneEntity, buf: &mut Vec<u8>) {
        let cube_pose = e.cubes.first().and_then(|c| c.pose);
        let text_pose = e.texts.first().and_then(|t| t.pose);
        let cube = opt_len(1, &cube_pose) + self.cube_tail.len();
        let text = opt_len(1, &text_pose) + self.text_tail.len();
        let mut len = opt_len(1, &e.timestamp) + self.entity.len();
        if !e.cubes.is_empty() {
            len += field_len(8, cube);
        }
        if !e.texts.is_empty() {
            len += field_len(13, text);
        }
        head(2, len, buf);
        opt(1, &e.timestamp, buf);
        buf.extend_from_slice(&self.entity);
        if !e.cubes.is_empty() {
            head(8, cube, buf);
            opt(1, &cube_pose, buf);
            buf.extend_from_slice(&self.cube_tail);
        }
        if !e.texts.is_empty() {
            head(13, text, buf);
            opt(1, &text_pose, buf);
            buf.extend_from_slice(&self.text_tail);
        }
    }

    /// `tf` as a FrameTransforms `transforms` field.
    pub(super) fn transform(&self, tf: &fg::FrameTransform, buf: &mut Vec<u8>) {
        let len = opt_len(1, &tf.timestamp)
            + self.transform.len()
            + opt_len(4, &tf.translation)
            + opt_len(5, &tf.rotation);
        head(1, len, buf);
        opt(1, &tf.timestamp, buf);
        buf.extend_from_slice(&self.transform);
        opt(4, &tf.translation, buf);
        opt(5, &tf.rotation, buf);
    }

    /// `o` (with the tick's motion in its base) as a GroundTruth
    /// `moving_object` field.
    pub(super) fn object(&self, o: &osi3::MovingObject, buf: &mut Vec<u8>) {
        let base = o.base.as_ref().map(|b| {
            self.dimension.len()
                + opt_len(2, &b.position)
                + opt_len(3, &b.orientation)
                + opt_len(4, &b.velocity)
                + opt_len(5, &b.acceleration)
                + opt_len(6, &b.orientation_rate)
        });
        let len =
            self.object_id.len() + base.map_or(0, |n| field_len(2, n)) + self.object_tail.len();
        head(5, len, buf);
        buf.extend_from_slice(&self.object_id);
        if let (Some(b), Some(n)) = (&o.base, base) {
            head(2, n, buf);
            buf.extend_from_slice(&self.dimension);
            opt(2, &b.position, buf);
            opt(3, &b.orientation, buf);
            opt(4, &b.velocity, buf);
            opt(5, &b.acceleration, buf);
            opt(6, &b.orientation_rate, buf);
        }
        buf.extend_from_slice(&self.object_tail);
    }
}

/// Which whole message a debug build compares with prost's encoding.
#[cfg(debug_assertions)]
pub(super) enum Whole {
    Scene,
    Transforms,
    /// The ground truth, after this many bytes of static map content.
    GroundTruth(usize),
}

#[cfg(debug_assertions)]
impl<W: Write + Seek> McapStream<W> {
    /// The pieced-together message equals prost's encoding of the whole
    /// message, byte for byte (every debug test run checks every tick).
    pub(super) fn check_against_prost(&self, which: Whole) {
        use prost::Message;
        let live = &self.live;
        match which {
            Whole::Scene => {
                let whole = fg::SceneUpdate {
                    deletions: self.deletions.clone(),
                    entities: live.iter().map(|&a| self.entities[a].clone()).collect(),
                };
                assert_eq!(self.buf, whole.encode_to_vec(), "SceneUpdate");
            }
            Whole::Transforms => {
                let whole = fg::FrameTransforms {
                    transforms: live.iter().map(|&a| self.transforms[a].clone()).collect(),
                };
                assert_eq!(self.buf, whole.encode_to_vec(), "FrameTransforms");
            }
            Whole::GroundTruth(at) => {
                let whole = osi3::GroundTruth {
                    moving_object: live.iter().map(|&a| self.objects[a].clone()).collect(),
                    ..self.gt.clone()
                };
                assert_eq!(self.gt_buf[at..], whole.encode_to_vec(), "GroundTruth");
            }
        }
    }
}
