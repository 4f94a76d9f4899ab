//! The node tree both FBX encodings hold: binary records and ASCII text are
//! read into the same [`Node`]s, so everything above reads one structure.
//!
//! A node has a name, a list of values (a binary record's attributes, or the
//! ASCII values after `Name:`) and children. Arrays are one value each.

/// One value of a node.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// An integer (binary `C Y I L`, an ASCII integer).
    Int(i64),
    /// A real number (binary `F D`, an ASCII number with a point or exponent).
    Float(f64),
    /// Text (binary `S`, read lossily when it is not UTF-8; an ASCII string or bare word).
    String(String),
    /// Bytes (binary `R`).
    Raw(Vec<u8>),
    /// An array of integers (binary `i l b c`; ASCII arrays of integers).
    Ints(Vec<i64>),
    /// An array of reals (binary `f d`; ASCII arrays with a real among them).
    Floats(Vec<f64>),
}

impl Value {
    /// The value as a number, whatever its stored type.
    pub fn number(&self) -> Option<f64> {
        match *self {
            Value::Int(v) => Some(v as f64),
            Value::Float(v) => Some(v),
            _ => None,
        }
    }

    /// The value as an integer (a real only when it is whole).
    pub fn int(&self) -> Option<i64> {
        match *self {
            Value::Int(v) => Some(v),
            Value::Float(v) if v.fract() == 0.0 && v.abs() < 9.0e18 => Some(v as i64),
            _ => None,
        }
    }

    /// The value as text.
    pub fn string(&self) -> Option<&str> {
        match self {
            Value::String(s) => Some(s),
            _ => None,
        }
    }

    /// The array as reals (integers converted).
    pub fn floats(&self) -> Option<Vec<f64>> {
        match self {
            Value::Floats(v) => Some(v.clone()),
            Value::Ints(v) => Some(v.iter().map(|&x| x as f64).collect()),
            Value::Float(v) => Some(vec![*v]),
            Value::Int(v) => Some(vec![*v as f64]),
            _ => None,
        }
    }

    /// The array as integers (reals only when every one is whole).
    pub fn ints(&self) -> Option<Vec<i64>> {
        match self {
            Value::Ints(v) => Some(v.clone()),
            Value::Floats(v) => v.iter().map(|&x| Value::Float(x).int()).collect(),
            Value::Int(v) => Some(vec![*v]),
            _ => None,
        }
    }

    /// Short name of the stored type, for errors.
    pub fn kind(&self) -> &'static str {
        match self {
            Value::Int(_) => "an integer",
            Value::Float(_) => "a number",
            Value::String(_) => "text",
            Value::Raw(_) => "raw bytes",
            Value::Ints(_) => "an array of integers",
            Value::Floats(_) => "an array of numbers",
        }
    }
}

/// One node: a name, its values and its children, in file order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Node {
    /// The node's name (`Model`, `Vertices`, `P`...).
    pub name: String,
    /// Its values.
    pub values: Vec<Value>,
    /// Its children.
    pub children: Vec<Node>,
}

impl Node {
    /// The first child called `name`.
    pub fn child(&self, name: &str) -> Option<&Node> {
        self.children.iter().find(|c| c.name == name)
    }

    /// Every child called `name`, in file order.
    pub fn children_named<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a Node> + 'a {
        self.children.iter().filter(move |c| c.name == name)
    }

    /// Value `index` of the node.
    pub fn value(&self, index: usize) -> Option<&Value> {
        self.values.get(index)
    }

    /// The first value of child `name`.
    pub fn child_value(&self, name: &str) -> Option<&Value> {
        self.child(name)?.values.first()
    }

    /// The text of child `name`.
    pub fn child_string(&self, name: &str) -> Option<&str> {
        self.child_value(name)?.string()
    }

    /// The number of child `name`.
    pub fn child_number(&self, name: &str) -> Option<f64> {
        self.child_value(name)?.number()
    }

    /// The array of child `name` as reals, with an error naming what is wrong.
    pub fn child_floats(&self, name: &str) -> Result<Vec<f64>, String> {
        let value = self.child_value(name).ok_or_else(|| format!("{} has no {name}", self.name))?;
        value.floats().ok_or_else(|| format!("{name} of {} is {}, not an array of numbers", self.name, value.kind()))
    }

    /// The array of child `name` as integers, with an error naming what is wrong.
    pub fn child_ints(&self, name: &str) -> Result<Vec<i64>, String> {
        let value = self.child_value(name).ok_or_else(|| format!("{} has no {name}", self.name))?;
        value.ints().ok_or_else(|| format!("{name} of {} is {}, not an array of integers", self.name, value.kind()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_convert_between_integers_and_reals() {
        assert_eq!(Value::Int(3).number(), Some(3.0));
        assert_eq!(Value::Float(3.0).int(), Some(3));
        assert_eq!(Value::Float(3.5).int(), None);
        assert_eq!(Value::Ints(vec![1, -2]).floats(), Some(vec![1.0, -2.0]));
        assert_eq!(Value::Floats(vec![1.0, -2.0]).ints(), Some(vec![1, -2]));
        assert_eq!(Value::Floats(vec![1.5]).ints(), None);
        assert_eq!(Value::String("x".into()).number(), None);
    }

    #[test]
    fn arrays_that_are_missing_or_of_the_wrong_kind_are_named() {
        let node = Node {
            name: "Geometry".into(),
            values: Vec::new(),
            children: vec![Node { name: "Vertices".into(), values: vec![Value::String("x".into())], children: vec![] }],
        };
        assert_eq!(node.child_floats("Vertices").unwrap_err(), "Vertices of Geometry is text, not an array of numbers");
        assert_eq!(node.child_ints("Indexes").unwrap_err(), "Geometry has no Indexes");
    }
}
