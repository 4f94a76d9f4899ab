//! Reading values out of FBX nodes: `Properties70` entries and data arrays,
//! with errors that say which value was wrong.

use fbxcel_dom::fbxcel::low::v7400::AttributeValue;
use fbxcel_dom::fbxcel::tree::v7400::NodeHandle;
use nalgebra::Vector3;

/// The value attributes of property `name` in the node's `Properties70`
/// (after the name, type, label and flags).
pub fn property<'a>(node: &NodeHandle<'a>, name: &str) -> Option<&'a [AttributeValue]> {
    let properties = node.first_child_by_name("Properties70")?;
    properties
        .children_by_name("P")
        .find(|p| p.attributes().first().and_then(AttributeValue::get_string) == Some(name))
        .and_then(|p| p.attributes().get(4..))
}

/// A number as f64, whatever its stored type.
pub fn number(value: &AttributeValue) -> Option<f64> {
    match *value {
        AttributeValue::F64(v) => Some(v),
        AttributeValue::F32(v) => Some(f64::from(v)),
        AttributeValue::I64(v) => Some(v as f64),
        AttributeValue::I32(v) => Some(f64::from(v)),
        AttributeValue::I16(v) => Some(f64::from(v)),
        AttributeValue::Bool(v) => Some(f64::from(u8::from(v))),
        _ => None,
    }
}

/// A numeric property.
pub fn number_property(node: &NodeHandle<'_>, name: &str) -> Option<f64> {
    property(node, name)?.first().and_then(number)
}

/// A three-component property (a vector or a colour).
pub fn vector_property(node: &NodeHandle<'_>, name: &str) -> Option<Vector3<f64>> {
    let values = property(node, name)?;
    Some(Vector3::new(number(values.first()?)?, number(values.get(1)?)?, number(values.get(2)?)?))
}

/// The array in child `name` as f64s (stored as doubles or floats).
pub fn float_array(node: &NodeHandle<'_>, name: &str) -> Result<Vec<f64>, String> {
    let child = node.first_child_by_name(name).ok_or_else(|| format!("{} has no {name}", node.name()))?;
    match child.attributes().first() {
        Some(AttributeValue::ArrF64(v)) => Ok(v.clone()),
        Some(AttributeValue::ArrF32(v)) => Ok(v.iter().map(|&x| f64::from(x)).collect()),
        Some(other) => Err(format!("{} of {} is {:?}, not an array of floats", name, node.name(), other.type_())),
        None => Err(format!("{} of {} is empty", name, node.name())),
    }
}

/// The array in child `name` as i64s (stored as 32- or 64-bit integers).
pub fn int_array(node: &NodeHandle<'_>, name: &str) -> Result<Vec<i64>, String> {
    let child = node.first_child_by_name(name).ok_or_else(|| format!("{} has no {name}", node.name()))?;
    match child.attributes().first() {
        Some(AttributeValue::ArrI32(v)) => Ok(v.iter().map(|&x| i64::from(x)).collect()),
        Some(AttributeValue::ArrI64(v)) => Ok(v.clone()),
        Some(other) => Err(format!("{} of {} is {:?}, not an array of integers", name, node.name(), other.type_())),
        None => Err(format!("{} of {} is empty", name, node.name())),
    }
}

/// The string in child `name`, if any.
pub fn child_string<'a>(node: &NodeHandle<'a>, name: &str) -> Option<&'a str> {
    node.first_child_by_name(name)?.attributes().first()?.get_string()
}
