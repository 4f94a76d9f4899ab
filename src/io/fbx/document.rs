//! The FBX 7 document over a [`Node`] tree: objects by id, connections,
//! and properties with their templates' defaults. Everything keeps the
//! file's order (objects, connections), so every choice made from a
//! document is the same on every run.

use std::collections::BTreeMap;

use nalgebra::Vector3;

use super::tree::{Node, Value};

/// One object of the `Objects` section.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Its id.
    pub id: i64,
    /// Its class: the node's name (`Model`, `Geometry`, `Deformer`,
    /// `AnimationStack`...).
    pub class: String,
    /// Its subclass (`Mesh`, `LimbNode`, `Skin`, `Cluster`...).
    pub subclass: String,
    /// Its name, without the class.
    pub name: String,
    /// Index of its node among the `Objects` node's children.
    node: usize,
}

/// A connection from a source object to a destination object or to one of
/// its properties (`OP`, with the property's name).
#[derive(Clone, Debug, PartialEq)]
pub struct Connection {
    /// The child in the FBX sense (a Geometry connects to its Model).
    pub source: i64,
    /// The parent (a Model's parent, a Deformer's Geometry...).
    pub destination: i64,
    /// The destination's property, for object-to-property connections.
    pub property: Option<String>,
}

/// An FBX 7 document.
#[derive(Debug)]
pub struct Document {
    /// FBX version × 1000.
    pub version: u32,
    /// Whether the file was ASCII text (else binary).
    pub ascii: bool,
    root: Node,
    objects: Vec<Object>,
    index_of: BTreeMap<i64, usize>,
    connections: Vec<Connection>,
    /// Per object, the connections it is the destination of, in file order.
    incoming: Vec<Vec<usize>>,
    /// Per object, the connections it is the source of, in file order.
    outgoing: Vec<Vec<usize>>,
    /// Per class, the path of its property template's `Properties70`
    /// (indices into `Definitions`' children).
    templates: BTreeMap<String, (usize, usize)>,
}

impl Document {
    /// Indexes the objects, connections and templates of `root`, a file of
    /// `version` in ASCII (`ascii`) or binary.
    pub fn new(root: Node, version: u32, ascii: bool) -> Document {
        let mut document = Document {
            version,
            ascii,
            objects: Vec::new(),
            index_of: BTreeMap::new(),
            connections: Vec::new(),
            incoming: Vec::new(),
            outgoing: Vec::new(),
            templates: BTreeMap::new(),
            root,
        };
        document.read_objects();
        document.read_connections();
        document.read_templates();
        document
    }

    fn read_objects(&mut self) {
        let Some(objects) = self.root.child("Objects") else { return };
        for (node, object) in objects.children.iter().enumerate() {
            let Some(id) = object.value(0).and_then(Value::int) else { continue };
            let name = object_name(object.value(1).and_then(Value::string).unwrap_or(""));
            let class = object.name.clone();
            let subclass = object.value(2).and_then(Value::string).unwrap_or("").to_owned();
            // The first object of an id wins; a repeated id is ignored.
            if self.index_of.contains_key(&id) {
                continue;
            }
            self.index_of.insert(id, self.objects.len());
            self.objects.push(Object { id, class, subclass, name, node });
        }
        self.incoming = vec![Vec::new(); self.objects.len()];
        self.outgoing = vec![Vec::new(); self.objects.len()];
    }

    fn read_connections(&mut self) {
        let Some(connections) = self.root.child("Connections") else { return };
        for c in connections.children_named("C") {
            let kind = c.value(0).and_then(Value::string).unwrap_or("");
            let (Some(source), Some(destination)) = (c.value(1).and_then(Value::int), c.value(2).and_then(Value::int))
            else {
                continue;
            };
            let property = match kind {
                "OO" => None,
                "OP" => c.value(3).and_then(Value::string).map(str::to_owned),
                _ => continue, // property-to-object links carry nothing a body uses
            };
            let index = self.connections.len();
            self.connections.push(Connection { source, destination, property });
            if let Some(&d) = self.index_of.get(&destination) {
                self.incoming[d].push(index);
            }
            if let Some(&s) = self.index_of.get(&source) {
                self.outgoing[s].push(index);
            }
        }
    }

    fn read_templates(&mut self) {
        let Some(definitions) = self.root.child("Definitions") else { return };
        for (t, object_type) in definitions.children.iter().enumerate() {
            let Some(class) = object_type.value(0).and_then(Value::string) else { continue };
            let template = object_type.children.iter().position(|c| c.name == "PropertyTemplate");
            if let Some(p) = template {
                self.templates.entry(class.to_owned()).or_insert((t, p));
            }
        }
    }

    /// The top-level node called `name` (`GlobalSettings`, `Takes`...).
    pub fn section(&self, name: &str) -> Option<&Node> {
        self.root.child(name)
    }

    /// Every object, in file order.
    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// The object of `id`.
    pub fn object(&self, id: i64) -> Option<&Object> {
        self.objects.get(*self.index_of.get(&id)?)
    }

    /// The node of `object`.
    pub fn node(&self, object: &Object) -> &Node {
        static EMPTY: Node = Node { name: String::new(), values: Vec::new(), children: Vec::new() };
        self.root.child("Objects").and_then(|o| o.children.get(object.node)).unwrap_or(&EMPTY)
    }

    /// Objects connected to `object` as sources (its children), with the
    /// property each connects to, in file order.
    pub fn sources<'a>(&'a self, object: &Object) -> impl Iterator<Item = (&'a Object, Option<&'a str>)> + 'a {
        let list = self.index_of.get(&object.id).and_then(|&i| self.incoming.get(i));
        list.into_iter().flatten().filter_map(move |&c| {
            let connection = &self.connections[c];
            Some((self.object(connection.source)?, connection.property.as_deref()))
        })
    }

    /// Objects `object` connects to (its parents), with the property, in file order.
    pub fn destinations<'a>(&'a self, object: &Object) -> impl Iterator<Item = (&'a Object, Option<&'a str>)> + 'a {
        let list = self.index_of.get(&object.id).and_then(|&i| self.outgoing.get(i));
        list.into_iter().flatten().filter_map(move |&c| {
            let connection = &self.connections[c];
            Some((self.object(connection.destination)?, connection.property.as_deref()))
        })
    }

    /// The values of property `name` of `object` (after its name, type,
    /// label and flags), from the object or else its class's template.
    pub fn property(&self, object: &Object, name: &str) -> Option<&[Value]> {
        own_property(self.node(object), name).or_else(|| {
            let &(t, p) = self.templates.get(&object.class)?;
            let template = self.root.child("Definitions")?.children.get(t)?.children.get(p)?;
            own_property(template, name)
        })
    }

    /// A numeric property.
    pub fn number(&self, object: &Object, name: &str) -> Option<f64> {
        self.property(object, name)?.first()?.number()
    }

    /// A three-component property (a vector or a colour).
    pub fn vector(&self, object: &Object, name: &str) -> Option<Vector3<f64>> {
        let values = self.property(object, name)?;
        Some(Vector3::new(values.first()?.number()?, values.get(1)?.number()?, values.get(2)?.number()?))
    }
}

/// Property `name` among a node's `Properties70` (values after name, type,
/// label, flags) or FBX 6's `Properties60` (after name, type, flags).
fn own_property<'a>(node: &'a Node, name: &str) -> Option<&'a [Value]> {
    let (list, entry, skip) = match node.child("Properties70") {
        Some(list) => (list, "P", 4),
        None => (node.child("Properties60")?, "Property", 3),
    };
    let found = list.children_named(entry).find(|p| p.value(0).and_then(Value::string) == Some(name))?;
    found.values.get(skip..)
}

/// An object's name from its stored name: binary files write
/// `Name\0\x01Class`, ASCII files `Class::Name` (the class is the node's
/// name, `AnimationStack` where this says `AnimStack`).
fn object_name(stored: &str) -> String {
    if let Some((name, _)) = stored.split_once("\u{0}\u{1}") {
        return name.to_owned();
    }
    stored.split_once("::").map_or(stored, |(_, name)| name).to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(name: &str, values: Vec<Value>, children: Vec<Node>) -> Node {
        Node { name: name.into(), values, children }
    }

    fn s(text: &str) -> Value {
        Value::String(text.into())
    }

    fn p(name: &str, values: Vec<Value>) -> Node {
        let mut all = vec![s(name), s("t"), s(""), s("A")];
        all.extend(values);
        node("P", all, vec![])
    }

    fn document() -> Document {
        let template = node(
            "ObjectType",
            vec![s("Model")],
            vec![node(
                "PropertyTemplate",
                vec![s("FbxNode")],
                vec![node("Properties70", vec![], vec![p("InheritType", vec![Value::Int(1)])])],
            )],
        );
        let model = |id: i64, name: &str, props: Vec<Node>| {
            node("Model", vec![Value::Int(id), s(name), s("Mesh")], vec![node("Properties70", vec![], props)])
        };
        let objects = node(
            "Objects",
            vec![],
            vec![
                model(10, "Hips\u{0}\u{1}Model", vec![]),
                model(11, "Model::Leg", vec![p("InheritType", vec![Value::Int(2)])]),
                model(10, "Duplicate\u{0}\u{1}Model", vec![]),
            ],
        );
        let c = |kind: &str, a: i64, b: i64| node("C", vec![s(kind), Value::Int(a), Value::Int(b)], vec![]);
        let connections = node("Connections", vec![], vec![c("OO", 10, 0), c("OO", 11, 10), c("XX", 11, 0)]);
        let definitions = node("Definitions", vec![], vec![template]);
        Document::new(node("", vec![], vec![definitions, objects, connections]), 7400, false)
    }

    #[test]
    fn names_classes_and_connections_follow_the_file() {
        let d = document();
        let names: Vec<_> = d.objects().iter().map(|o| (o.name.as_str(), o.class.as_str())).collect();
        assert_eq!(names, [("Hips", "Model"), ("Leg", "Model")]);
        let hips = d.object(10).unwrap();
        let leg = d.object(11).unwrap();
        assert_eq!(d.sources(hips).map(|(o, _)| o.id).collect::<Vec<_>>(), [11]);
        assert_eq!(d.destinations(leg).map(|(o, _)| o.id).collect::<Vec<_>>(), [10]);
    }

    #[test]
    fn properties_fall_back_to_the_class_template() {
        let d = document();
        assert_eq!(d.number(d.object(10).unwrap(), "InheritType"), Some(1.0));
        assert_eq!(d.number(d.object(11).unwrap(), "InheritType"), Some(2.0));
        assert_eq!(d.number(d.object(11).unwrap(), "Missing"), None);
    }
}
