//! Animation stacks, layers, curve nodes and curves of an FBX 7 document
//! into a [`Motion`]: which values of which nodes and blend-shape channels
//! move, with the tangents FBX stores (or leaves to be recomputed) and
//! what each curve does outside its keys.

use super::document::{Document, Object};
use super::tree::{Node, Value};
use crate::body::curve::{Curve, Extrapolation, ExtrapolationMode, Handle, Interpolation, Key, TICKS_PER_SECOND};
use crate::body::motion::{Animated, LayerBlend, LayerValue, Motion, NodeAnimation, ShapeAnimation};
use crate::body::skeleton::Skeleton;

/// FBX 8000's time unit, ticks per second.
const TICKS_PER_SECOND_8000: f64 = 141_120_000.0;

/// The file's time unit, ticks per second.
pub fn ticks_per_second(document: &Document) -> f64 {
    let header = document.section("FBXHeaderExtension");
    let flags = header.and_then(|h| h.child("OtherFlags"));
    let definition = flags.and_then(|f| f.child_value("TCDefinition")).and_then(Value::int);
    let header_version = header.and_then(|h| h.child_value("FBXHeaderVersion")).and_then(Value::int).unwrap_or(0);
    let new_unit = document.version >= 8000 || (header_version >= 1004 && definition.is_some_and(|d| d != 127));
    if new_unit { TICKS_PER_SECOND_8000 } else { TICKS_PER_SECOND }
}

/// The file's animation stacks in file order.
pub fn stacks(document: &Document) -> Vec<&Object> {
    document.objects().iter().filter(|o| o.class == "AnimationStack").collect()
}

/// Chooses a stack: by name (exactly, or the part after the last `|` as
/// Blender names actions `Armature|Walk`), or else the first. An unknown
/// name is an error listing the stacks.
pub fn choose_stack<'a>(document: &'a Document, name: Option<&str>) -> Result<Option<&'a Object>, String> {
    let all = stacks(document);
    let Some(wanted) = name else { return Ok(all.first().copied()) };
    let exact = all.iter().find(|s| s.name == wanted);
    let short = || all.iter().find(|s| s.name.rsplit('|').next() == Some(wanted));
    match exact.or_else(short) {
        Some(s) => Ok(Some(*s)),
        None if all.is_empty() => Err(format!("there is no animation stack '{wanted}': the file has no animation")),
        None => {
            let names: Vec<String> = all.iter().map(|s| format!("'{}'", s.name)).collect();
            Err(format!("there is no animation stack '{wanted}'; the file has {}", names.join(", ")))
        }
    }
}

/// Everything a motion is read against: the document, its time unit, and
/// the skeleton's bone index of each Model id.
pub struct Targets<'a> {
    /// The document.
    pub document: &'a Document,
    /// The skeleton the motion drives (the file's Models).
    pub skeleton: &'a Skeleton,
    /// The bone index of a Model id.
    pub bone_of: &'a dyn Fn(i64) -> Option<usize>,
}

/// The motion of `stack`; `None` when it animates nothing drape uses.
pub fn motion(targets: &Targets<'_>, stack: &Object, reference_height: f64) -> Result<Option<Motion>, String> {
    let document = targets.document;
    let unit = ticks_per_second(document);
    let mut nodes: Vec<NodeAnimation> = Vec::new();
    let mut shapes: Vec<ShapeAnimation> = Vec::new();
    let mut keyed = (f64::INFINITY, f64::NEG_INFINITY);
    for layer in active_layers(document, stack) {
        let base = layer_value_template(document, layer);
        for (curve_node, _) in document.sources(layer).filter(|(o, _)| o.class == "AnimationCurveNode") {
            let Some((target, property)) = document.destinations(curve_node).find_map(|(o, p)| Some((o, p?))) else {
                continue;
            };
            let Some(slot) = slot_for(targets, target, property, &mut nodes, &mut shapes) else { continue };
            let value = layer_value(document, curve_node, &base, unit, &mut keyed)?;
            slot.layers.push(value);
        }
    }
    if nodes.is_empty() && shapes.is_empty() {
        return Ok(None);
    }
    nodes.sort_by_key(|n| n.bone);
    let (start_s, end_s) = span(document, stack, unit, keyed);
    let source = targets.skeleton.clone();
    Ok(Some(Motion { name: stack.name.clone(), source, nodes, shapes, start_s, end_s, reference_height }))
}

/// The layers of a stack in connection order, without muted ones (and only
/// the solo ones when any is solo).
fn active_layers<'a>(document: &'a Document, stack: &Object) -> Vec<&'a Object> {
    let layers: Vec<&Object> =
        document.sources(stack).map(|(o, _)| o).filter(|o| o.class == "AnimationLayer").collect();
    let flag = |o: &Object, name: &str| document.number(o, name).is_some_and(|v| v != 0.0);
    let solo = layers.iter().any(|l| flag(l, "Solo"));
    layers.into_iter().filter(|l| !flag(l, "Mute") && (!solo || flag(l, "Solo"))).collect()
}

/// A layer's blend mode, weight and accumulation modes (no components yet).
fn layer_value_template(document: &Document, layer: &Object) -> LayerValue {
    let number = |name: &str, default: f64| document.number(layer, name).filter(|v| v.is_finite()).unwrap_or(default);
    let weight = number("Weight", 100.0) / 100.0;
    LayerValue {
        blend: match number("BlendMode", 0.0) as i64 {
            1 => LayerBlend::Override,
            2 => LayerBlend::Passthrough,
            _ => LayerBlend::Additive,
        },
        weight: if weight > 0.99999 { 1.0 } else { weight.clamp(0.0, 1.0) },
        rotation_by_channel: number("RotationAccumulationMode", 0.0) == 1.0,
        scale_additive: number("ScaleAccumulationMode", 0.0) == 1.0,
        components: Vec::new(),
    }
}

/// The animated property a curve node drives: a node's transform channel
/// or a blend-shape channel's weight. Other properties are not used.
fn slot_for<'s>(
    targets: &Targets<'_>,
    target: &Object,
    property: &str,
    nodes: &'s mut Vec<NodeAnimation>,
    shapes: &'s mut Vec<ShapeAnimation>,
) -> Option<&'s mut Animated> {
    if target.class == "Deformer" && target.subclass == "BlendShapeChannel" && property == "DeformPercent" {
        let index = match shapes.iter().position(|s| s.channel == target.name) {
            Some(i) => i,
            None => {
                shapes.push(ShapeAnimation { channel: target.name.clone(), percent: Animated::default() });
                shapes.len() - 1
            }
        };
        return Some(&mut shapes[index].percent);
    }
    if target.class != "Model" || !matches!(property, "Lcl Translation" | "Lcl Rotation" | "Lcl Scaling") {
        return None;
    }
    let bone = (targets.bone_of)(target.id)?;
    let index = match nodes.iter().position(|n| n.bone == bone) {
        Some(i) => i,
        None => {
            nodes.push(NodeAnimation { bone, ..Default::default() });
            nodes.len() - 1
        }
    };
    let node = &mut nodes[index];
    let slot = match property {
        "Lcl Translation" => &mut node.translation,
        "Lcl Rotation" => &mut node.rotation,
        _ => &mut node.scaling,
    };
    Some(slot.get_or_insert_with(Animated::default))
}

/// One curve node's value in a layer: per component its curve and its
/// default (`d|X`... in the curve node's properties).
fn layer_value(
    document: &Document,
    curve_node: &Object,
    base: &LayerValue,
    unit: f64,
    keyed: &mut (f64, f64),
) -> Result<LayerValue, String> {
    let scalar = document.property(curve_node, "d|X").is_none();
    let mut components: Vec<(Option<Curve>, f64)> = match scalar {
        true => vec![(None, first_default(document, curve_node).unwrap_or(0.0))],
        false => {
            ["d|X", "d|Y", "d|Z"].iter().map(|name| (None, document.number(curve_node, name).unwrap_or(0.0))).collect()
        }
    };
    for value in &mut components {
        if !value.1.is_finite() {
            value.1 = 0.0;
        }
    }
    for (curve, label) in document.sources(curve_node).filter(|(o, _)| o.class == "AnimationCurve") {
        let component = match label {
            Some("d|Y") | Some("Y") => 1,
            Some("d|Z") | Some("Z") => 2,
            _ => 0,
        };
        let Some(slot) = components.get_mut(component) else { continue };
        let curve = read_curve(document.node(curve), unit).map_err(|e| format!("animation curve {}: {e}", curve.id))?;
        if let (Some(a), Some(b)) = (curve.keys.first(), curve.keys.last()) {
            *keyed = (keyed.0.min(a.time_s), keyed.1.max(b.time_s));
        }
        slot.0 = Some(curve);
    }
    Ok(LayerValue { components, ..base.clone() })
}

/// A scalar curve node's default: its one `d|...` property.
fn first_default(document: &Document, curve_node: &Object) -> Option<f64> {
    let node = document.node(curve_node);
    let list = node.child("Properties70")?;
    let p =
        list.children_named("P").find(|p| p.value(0).and_then(Value::string).is_some_and(|n| n.starts_with("d|")))?;
    p.value(4)?.number()
}

/// The stack's span: `LocalStart`..`LocalStop`, else the reference span,
/// else the keys' own.
fn span(document: &Document, stack: &Object, unit: f64, keyed: (f64, f64)) -> (f64, f64) {
    let seconds = |name: &str| document.number(stack, name).filter(|v| v.is_finite()).map(|t| t / unit);
    for (a, b) in [("LocalStart", "LocalStop"), ("ReferenceStart", "ReferenceStop")] {
        if let (Some(start), Some(stop)) = (seconds(a), seconds(b))
            && stop > start
        {
            return (start, stop);
        }
    }
    if keyed.1 >= keyed.0 { keyed } else { (0.0, 0.0) }
}

/// Flag bits of `KeyAttrFlags`.
mod flags {
    pub const CONSTANT: i64 = 0x2;
    pub const CUBIC: i64 = 0x8;
    pub const CONSTANT_NEXT: i64 = 0x100;
    pub const TCB: i64 = 0x200;
    pub const USER: i64 = 0x400;
    pub const CLAMP: i64 = 0x1000;
    pub const TIME_INDEPENDENT: i64 = 0x2000;
    pub const CLAMP_PROGRESSIVE: i64 = 0x4000;
    pub const WEIGHTED_RIGHT: i64 = 0x0100_0000;
    pub const WEIGHTED_NEXT_LEFT: i64 = 0x0200_0000;
}

/// One key's stored attributes: its flag word and four data words.
#[derive(Clone, Copy)]
struct Attributes {
    flags: i64,
    data: [f32; 4],
}

impl Attributes {
    /// The right and next-left weights packed in the third data word
    /// (1/10 000 each), where the flags say they are there; else a third.
    fn weights(&self) -> (f64, f64) {
        let packed = self.data[2].to_bits();
        let right = f64::from(packed & 0xffff) / 10_000.0;
        let next_left = f64::from(packed >> 16) / 10_000.0;
        let third = 1.0 / 3.0;
        (
            if self.flags & flags::WEIGHTED_RIGHT != 0 { right } else { third },
            if self.flags & flags::WEIGHTED_NEXT_LEFT != 0 { next_left } else { third },
        )
    }
}

/// Reads one AnimationCurve: keys, their interpolation and tangent handles,
/// and its extrapolation.
pub fn read_curve(node: &Node, unit: f64) -> Result<Curve, String> {
    let times = node.child_ints("KeyTime")?;
    let values = node.child_floats("KeyValueFloat")?;
    if times.len() != values.len() {
        return Err(format!("{} key times but {} values", times.len(), values.len()));
    }
    let times_s: Vec<f64> = times.iter().map(|&t| t as f64 / unit).collect();
    if times_s.windows(2).any(|w| w[1] < w[0]) || values.iter().any(|v| !v.is_finite()) {
        return Err("keys out of time order or values that are not finite numbers".into());
    }
    let attributes = key_attributes(node, times.len())?;
    let mut curve = Curve { keys: Vec::with_capacity(times.len()), ..Default::default() };
    let mut incoming = (0.0, 1.0 / 3.0); // the left slope and weight the previous key hands on
    for (k, &attribute) in attributes.iter().enumerate() {
        let (key, next_incoming) = key_with_tangents(&times_s, &values, k, attribute, incoming);
        curve.keys.push(key);
        incoming = next_incoming;
    }
    curve.pre = extrapolation(node.child("Pre-Extrapolation"));
    curve.post = extrapolation(node.child("Post-Extrapolation"));
    Ok(curve)
}

/// Each key's attributes, from run lengths over the flag and data arrays.
fn key_attributes(node: &Node, count: usize) -> Result<Vec<Attributes>, String> {
    let flag_words = node.child_ints("KeyAttrFlags").unwrap_or_default();
    let data = data_words(node);
    let runs = node.child_ints("KeyAttrRefCount").unwrap_or_default();
    let linear = Attributes { flags: 0x4, data: [0.0; 4] };
    let mut out = Vec::with_capacity(count);
    for (j, &run) in runs.iter().enumerate() {
        let attributes = Attributes {
            flags: flag_words.get(j).copied().unwrap_or(0x4),
            data: std::array::from_fn(|w| data.get(4 * j + w).copied().unwrap_or(0.0)),
        };
        let run = usize::try_from(run).unwrap_or(0).min(count - out.len());
        out.extend(std::iter::repeat_n(attributes, run));
        if out.len() == count {
            break;
        }
    }
    out.resize(count, linear);
    Ok(out)
}

/// `KeyAttrDataFloat` as 32-bit words: binary files store floats, ASCII
/// files from 7.2 on print each word's bit pattern as an integer.
fn data_words(node: &Node) -> Vec<f32> {
    match node.child_value("KeyAttrDataFloat") {
        Some(Value::Ints(words)) => words.iter().map(|&w| f32::from_bits(w as i32 as u32)).collect(),
        Some(Value::Floats(words)) => words.iter().map(|&w| w as f32).collect(),
        _ => Vec::new(),
    }
}

/// Key `k` with its interpolation and handles (the FBX SDK's rules: user
/// slopes as stored, automatic ones recomputed from the neighbours, TCB
/// from tension, continuity and bias), and what it hands the next key.
fn key_with_tangents(
    times: &[f64],
    values: &[f64],
    k: usize,
    a: Attributes,
    (left_in, left_weight): (f64, f64),
) -> (Key, (f64, f64)) {
    let (t, v) = (times[k], values[k]);
    let previous = k.checked_sub(1).map(|p| (times[p], values[p])).filter(|p| p.0 < t);
    let next = times.get(k + 1).map(|&tn| (tn, values[k + 1])).filter(|n| n.0 > t);
    let (right_weight, next_left_weight) = a.weights();
    let third = 1.0 / 3.0;
    let cubic = a.flags & flags::CONSTANT == 0 && a.flags & flags::CUBIC != 0;
    let (interpolation, left_slope, right_slope, hand_on) = if a.flags & flags::CONSTANT != 0 {
        let mode = if a.flags & flags::CONSTANT_NEXT != 0 {
            Interpolation::ConstantNext
        } else {
            Interpolation::ConstantPrevious
        };
        (mode, left_in, 0.0, (0.0, third))
    } else if cubic {
        cubic_slopes(previous, (t, v), next, a, left_in, left_weight, right_weight, next_left_weight)
    } else {
        let slope = next.map_or(0.0, |(tn, vn)| (vn - v) / (tn - t));
        (Interpolation::Linear, left_in, slope, (slope, third))
    };
    let weight_right = if cubic { right_weight } else { third };
    // The incoming handle belongs to the segment before, which the
    // previous key shaped: its slope and weight as handed on.
    let left = previous.map_or(Handle::default(), |(tp, _)| {
        let dt = left_weight * (t - tp);
        Handle { dt_s: dt, dv: dt * left_slope }
    });
    let right = next.map_or(Handle::default(), |(tn, _)| {
        let dt = weight_right * (tn - t);
        Handle { dt_s: dt, dv: dt * right_slope }
    });
    (Key { time_s: t, value: v, interpolation, left, right }, hand_on)
}

/// The slopes of a cubic key: (interpolation, left slope, right slope, what
/// the next key takes in: its left slope and weight).
#[allow(clippy::too_many_arguments)]
fn cubic_slopes(
    previous: Option<(f64, f64)>,
    (t, v): (f64, f64),
    next: Option<(f64, f64)>,
    a: Attributes,
    left_in: f64,
    left_weight: f64,
    right_weight: f64,
    next_left_weight: f64,
) -> (Interpolation, f64, f64, (f64, f64)) {
    let [d0, d1, d2, _] = a.data.map(f64::from);
    if a.flags & flags::USER != 0 {
        return (Interpolation::Cubic, left_in, d0, (d1, next_left_weight));
    }
    let m_left = previous.map_or(0.0, |(tp, vp)| (v - vp) / (t - tp));
    let m_right = next.map_or(0.0, |(tn, vn)| (vn - v) / (tn - t));
    if a.flags & flags::TCB != 0 {
        let f = if previous.is_some() && next.is_some() { 0.5 } else { 1.0 };
        let (tension, continuity, bias) = (d0, d1, d2);
        let left = f
            * (1.0 - tension)
            * ((1.0 + bias) * (1.0 - continuity) * m_left + (1.0 - bias) * (1.0 + continuity) * m_right);
        let right = f
            * (1.0 - tension)
            * ((1.0 + bias) * (1.0 + continuity) * m_left + (1.0 - bias) * (1.0 - continuity) * m_right);
        return (Interpolation::Cubic, left, right, (0.0, 1.0 / 3.0));
    }
    let auto = AutoTangent { previous, key: (t, v), next, flags: a.flags, left_weight, right_weight };
    let (left, right) = match (previous, next) {
        (Some(_), Some(_)) if (left_in + d0).abs() <= 1e-4 => (auto.both(d0), auto.both(d0)),
        (Some(_), Some(_)) => (auto.both(-left_in), auto.both(d0)),
        (None, Some(_)) => (auto.one_sided(d0, false), auto.one_sided(d0, false)),
        (Some(_), None) => (auto.one_sided(-left_in, true), auto.one_sided(-left_in, true)),
        (None, None) => (0.0, 0.0),
    };
    (Interpolation::Cubic, left, right, (d1, next_left_weight))
}

/// An automatic tangent's inputs (the key, its neighbours, its flags).
struct AutoTangent {
    previous: Option<(f64, f64)>,
    key: (f64, f64),
    next: Option<(f64, f64)>,
    flags: i64,
    left_weight: f64,
    right_weight: f64,
}

impl AutoTangent {
    /// The slope through both neighbours, bent by `bias` (percent) towards
    /// one side, clamped (flat next to an equal neighbour, or no overshoot).
    fn both(&self, bias: f64) -> f64 {
        let (Some((tp, vp)), (t, v), Some((tn, vn))) = (self.previous, self.key, self.next) else { return 0.0 };
        if self.flags & flags::CLAMP != 0 && (vp - v).abs().min((vn - v).abs()) <= 0.0 {
            return 0.0;
        }
        let mut m = (vn - vp) / (tn - tp);
        if self.flags & flags::TIME_INDEPENDENT == 0 {
            let (m_left, m_right) = ((v - vp) / (t - tp), (vn - v) / (tn - t));
            let delta = (t - tp) / (tn - tp);
            m = 0.5 * m + 0.5 * ((1.0 - delta) * m_left + delta * m_right);
            let b = bias.abs() / 100.0;
            if b > 1e-4 {
                let target = if bias > 0.0 { m_right } else { m_left };
                let towards = target - m;
                m = (1.0 - b) * m + b * target;
                if b > 5.0 {
                    let sign = if towards.abs() > 1e-5 { towards.signum() } else { bias.signum() };
                    m += 40.0 * (b - 5.0) * (b - 5.0) * sign;
                }
            }
        }
        if self.flags & flags::CLAMP_PROGRESSIVE != 0 {
            let (sign, size) = (m.signum(), m.abs());
            let limit = |dv: f64, dt: f64| {
                let l = sign * dv / dt;
                if l.is_finite() && l > 0.0 { l } else { 0.0 }
            };
            let left_limit = limit(v - vp, self.left_weight * (t - tp));
            let right_limit = limit(vn - v, self.right_weight * (tn - t));
            m = sign * size.min(left_limit).min(right_limit);
        }
        m
    }

    /// The slope at an end key towards its one neighbour (`towards_previous`).
    fn one_sided(&self, bias: f64, towards_previous: bool) -> f64 {
        let (t, v) = self.key;
        let neighbour = if towards_previous { self.previous } else { self.next };
        let Some((tn, vn)) = neighbour else { return 0.0 };
        if self.flags & flags::CLAMP_PROGRESSIVE != 0 || (self.flags & flags::CLAMP != 0 && vn == v) {
            return 0.0;
        }
        let mut m = (vn - v) / (tn - t);
        let b = bias.abs() / 100.0;
        if self.flags & flags::TIME_INDEPENDENT == 0 && b > 5.0 {
            m += 40.0 * (b - 5.0) * (b - 5.0) * bias.signum();
        }
        m
    }
}

/// `Pre-Extrapolation` / `Post-Extrapolation`: a type letter (a byte in
/// binary files, a bare word in ASCII) and a repetition count (negative: no end).
fn extrapolation(node: Option<&Node>) -> Extrapolation {
    let Some(node) = node else { return Extrapolation::default() };
    let letter = match node.child_value("Type") {
        Some(Value::String(s)) => s.chars().next(),
        Some(v) => v.int().and_then(|c| u8::try_from(c).ok()).map(char::from),
        None => None,
    };
    let mode = match letter {
        Some('R') => ExtrapolationMode::Repeat,
        Some('A') => ExtrapolationMode::RepeatRelative,
        Some('M') => ExtrapolationMode::Mirror,
        Some('K') => ExtrapolationMode::KeepSlope,
        _ => ExtrapolationMode::Constant,
    };
    let repetitions = node.child_value("Repetition").and_then(Value::int).and_then(|r| u32::try_from(r).ok());
    Extrapolation { mode, repetitions }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn child(name: &str, value: Value) -> Node {
        Node { name: name.into(), values: vec![value], children: vec![] }
    }

    fn curve_node(times_s: &[f64], values: &[f64], flags: i64, data: [f32; 4]) -> Node {
        let ticks = times_s.iter().map(|t| (t * TICKS_PER_SECOND).round() as i64).collect();
        Node {
            name: "AnimationCurve".into(),
            values: vec![],
            children: vec![
                child("KeyTime", Value::Ints(ticks)),
                child("KeyValueFloat", Value::Floats(values.to_vec())),
                child("KeyAttrFlags", Value::Ints(vec![flags])),
                child("KeyAttrDataFloat", Value::Floats(data.iter().map(|&d| f64::from(d)).collect())),
                child("KeyAttrRefCount", Value::Ints(vec![values.len() as i64])),
            ],
        }
    }

    #[test]
    fn user_slopes_are_the_hermite_of_the_stored_slopes() {
        // Slopes 0 leaving the first key and 3 arriving: v = t³ on [0, 1].
        let node = curve_node(&[0.0, 1.0], &[0.0, 1.0], 0x8 | 0x400, [0.0, 3.0, 0.0, 0.0]);
        let c = read_curve(&node, TICKS_PER_SECOND).unwrap();
        assert!((c.value_at(0.5).unwrap() - 0.125).abs() < 1e-9);
    }

    #[test]
    fn ascii_data_words_are_bit_patterns() {
        let mut node = curve_node(&[0.0, 1.0], &[0.0, 1.0], 0x8 | 0x400, [0.0; 4]);
        node.children[3] = child("KeyAttrDataFloat", Value::Ints(vec![0, 3.0f32.to_bits() as i64, 218_434_821, 0]));
        let c = read_curve(&node, TICKS_PER_SECOND).unwrap();
        assert!((c.value_at(0.5).unwrap() - 0.125).abs() < 1e-9);
        // 0x0D050D05 packs two weights of 0.3333.
        let a = Attributes {
            flags: flags::WEIGHTED_RIGHT | flags::WEIGHTED_NEXT_LEFT,
            data: [0.0, 0.0, f32::from_bits(0x0D05_0D05), 0.0],
        };
        assert_eq!(a.weights(), (0.3333, 0.3333));
    }

    #[test]
    fn constant_keys_hold_or_jump_to_the_next() {
        let hold = read_curve(&curve_node(&[0.0, 1.0], &[2.0, 5.0], 0x2, [0.0; 4]), TICKS_PER_SECOND).unwrap();
        assert_eq!(hold.value_at(0.5), Some(2.0));
        let next = read_curve(&curve_node(&[0.0, 1.0], &[2.0, 5.0], 0x2 | 0x100, [0.0; 4]), TICKS_PER_SECOND).unwrap();
        assert_eq!(next.value_at(0.5), Some(5.0));
    }

    #[test]
    fn automatic_time_independent_tangents_are_centred_and_flat_at_ends_when_progressive() {
        let flags = 0x8 | 0x100 | flags::TIME_INDEPENDENT | flags::CLAMP_PROGRESSIVE;
        let c = read_curve(&curve_node(&[0.0, 1.0, 2.0], &[0.0, 1.0, 2.0], flags, [0.0; 4]), TICKS_PER_SECOND).unwrap();
        // A straight line of keys keeps its slope in the middle ...
        assert!((c.keys[1].right.dv / c.keys[1].right.dt_s - 1.0).abs() < 1e-12);
        // ... and flat ends (clamped progressive).
        assert_eq!(c.keys[0].right.dv, 0.0);
    }

    #[test]
    fn extrapolation_letters_come_as_bytes_or_words() {
        let ext = |value: Value, count: i64| Node {
            name: "Post-Extrapolation".into(),
            values: vec![],
            children: vec![child("Type", value), child("Repetition", Value::Int(count))],
        };
        let binary = extrapolation(Some(&ext(Value::Int(i64::from(b'M')), 3)));
        assert_eq!(binary, Extrapolation { mode: ExtrapolationMode::Mirror, repetitions: Some(3) });
        let ascii = extrapolation(Some(&ext(Value::String("A".into()), -1)));
        assert_eq!(ascii, Extrapolation { mode: ExtrapolationMode::RepeatRelative, repetitions: None });
    }

    #[test]
    fn broken_curves_are_errors() {
        let mut node = curve_node(&[1.0, 0.0], &[0.0, 1.0], 0x4, [0.0; 4]);
        assert!(read_curve(&node, TICKS_PER_SECOND).unwrap_err().contains("out of time order"));
        node.children[1] = child("KeyValueFloat", Value::Floats(vec![0.0]));
        assert!(read_curve(&node, TICKS_PER_SECOND).unwrap_err().contains("2 key times but 1 values"));
    }
}
