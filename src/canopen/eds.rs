//! Electronic data sheet (EDS) text after CiA 306 (v1.3, INI format) from an
//! [`ObjectDictionary`], so CANopen tools can load the daemon's objects by name.
//!
//! Sections: `[FileInfo]`, `[DeviceInfo]`, `[DummyUsage]`, `[Comments]`, the object lists
//! `[MandatoryObjects]` (1000h, 1001h, 1018h), `[OptionalObjects]` (the other 1000h..1FFFh) and
//! `[ManufacturerObjects]` (2000h..5FFFh), then one `[IIII]` section per object and one
//! `[IIIIsubS]` section per sub-entry of an ARRAY or RECORD (CiA 306 §4.6).
//!
//! CiA 306 has no access type for "writable only in pre-operational"; such entries are `rw`
//! and say so in their `Description`. `Unit` and `Description` are not CiA 306 keys, but tools
//! (e.g. the Python `canopen` package) read them. The output is deterministic: no dates unless
//! given.

use super::od::{Access, Entry, Object, ObjectDictionary, ObjectId, ObjectKind, Value};

/// What the EDS says about the file and the device.
#[derive(Debug, Clone, PartialEq)]
pub struct EdsInfo {
    pub file_name: String,
    pub file_version: u8,
    pub description: String,
    pub created_by: String,
    /// `hh:mm(AM|PM)` and `mm-dd-yyyy` per CiA 306; left out when `None`.
    pub creation_time: Option<String>,
    pub creation_date: Option<String>,
    pub vendor_name: String,
    pub product_name: String,
    /// Bit rates in kbit/s the device supports.
    pub baud_rates_kbit: Vec<u32>,
}

impl Default for EdsInfo {
    fn default() -> Self {
        Self {
            file_name: "actuatord.eds".into(),
            file_version: 1,
            description: "actuatord: actuator control daemon, object dictionary".into(),
            created_by: "actuatord".into(),
            creation_time: None,
            creation_date: None,
            vendor_name: "actuatord project".into(),
            product_name: "actuatord".into(),
            baud_rates_kbit: vec![125, 250, 500, 1000],
        }
    }
}

/// The CiA 306 object list an index belongs to (§4.5.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ObjectList {
    Mandatory,
    Optional,
    Manufacturer,
}

impl ObjectList {
    fn of(index: u16) -> Option<Self> {
        match index {
            0x1000 | 0x1001 | 0x1018 => Some(Self::Mandatory),
            0x1002..=0x1FFF => Some(Self::Optional),
            0x2000..=0x5FFF => Some(Self::Manufacturer),
            // The standardised device profile area (CiA 402, CiA 401 nodes).
            0x6000..=0x9FFF => Some(Self::Optional),
            _ => None,
        }
    }
}

/// CiA 306 baud rate keys.
const BAUD_RATES: [u32; 8] = [10, 20, 50, 125, 250, 500, 800, 1000];

/// Render the EDS text of `od`.
pub fn render_eds(od: &ObjectDictionary, info: &EdsInfo) -> String {
    let mut out = String::new();
    let mut w = |line: String| {
        out.push_str(&line);
        out.push_str("\r\n"); // CiA 306 files use DOS line ends.
    };
    w("[FileInfo]".into());
    w(format!("FileName={}", clean(&info.file_name)));
    w(format!("FileVersion={}", info.file_version));
    w("FileRevision=0".into());
    w("EDSVersion=4.0".into());
    w(format!("Description={}", clean(&info.description)));
    if let Some(t) = &info.creation_time {
        w(format!("CreationTime={}", clean(t)));
    }
    if let Some(d) = &info.creation_date {
        w(format!("CreationDate={}", clean(d)));
    }
    w(format!("CreatedBy={}", clean(&info.created_by)));
    w(String::new());
    w("[DeviceInfo]".into());
    w(format!("VendorName={}", clean(&info.vendor_name)));
    // Vendor, product and revision numbers are the identity object's (1018h), 0 without one.
    let identity = |sub| match od.read(ObjectId::new(0x1018, sub)) {
        Ok(Value::Unsigned32(v)) => v,
        _ => 0,
    };
    w(format!("VendorNumber=0x{:X}", identity(1)));
    w(format!("ProductName={}", clean(&info.product_name)));
    w(format!("ProductNumber=0x{:X}", identity(2)));
    w(format!("RevisionNumber=0x{:X}", identity(3)));
    w("OrderCode=".into());
    for rate in BAUD_RATES {
        w(format!(
            "BaudRate_{rate}={}",
            u8::from(info.baud_rates_kbit.contains(&rate))
        ));
    }
    let count = |range: std::ops::RangeInclusive<u16>| {
        od.objects()
            .iter()
            .filter(|o| range.contains(&o.index))
            .count()
    };
    let (rx, tx) = (count(0x1400..=0x15FF), count(0x1800..=0x19FF));
    // The daemon starts its actuator nodes: a simple NMT master, not a slave; its PDOs have a
    // fixed mapping (dbc/actuatord.dbc). A node with PDO parameters (a simulated CiA 402/401
    // node) is a slave whose PDOs are configured by its master.
    let slave = rx + tx > 0;
    w(format!("SimpleBootUpMaster={}", u8::from(!slave)));
    w(format!("SimpleBootUpSlave={}", u8::from(slave)));
    // Mapping granularity in bits: 8 where PDOs can be mapped, 0 where they cannot.
    w(format!("Granularity={}", if slave { 8 } else { 0 }));
    w(format!("DynamicChannelsSupported={}", u8::from(slave)));
    w("GroupMessaging=0".into());
    w(format!("NrOfRXPDO={rx}"));
    w(format!("NrOfTXPDO={tx}"));
    w("LSS_Supported=0".into());
    w(String::new());
    w("[DummyUsage]".into());
    for i in 1..=7 {
        w(format!("Dummy{i:04}=0"));
    }
    w(String::new());
    let comments = [
        "Generated from the object dictionary of actuatord.",
        "Entries marked 'writable in pre-operational only' are refused with SDO abort 08000022h while operational.",
        "Writes take effect at the next control cycle boundary.",
    ];
    w("[Comments]".into());
    w(format!("Lines={}", comments.len()));
    for (i, line) in comments.iter().enumerate() {
        w(format!("Line{}={line}", i + 1));
    }
    w(String::new());
    for (list, section) in [
        (ObjectList::Mandatory, "MandatoryObjects"),
        (ObjectList::Optional, "OptionalObjects"),
        (ObjectList::Manufacturer, "ManufacturerObjects"),
    ] {
        let indexes: Vec<u16> = od
            .objects()
            .iter()
            .map(|o| o.index)
            .filter(|&i| ObjectList::of(i) == Some(list))
            .collect();
        w(format!("[{section}]"));
        w(format!("SupportedObjects={}", indexes.len()));
        for (n, index) in indexes.iter().enumerate() {
            w(format!("{}=0x{index:04X}", n + 1));
        }
        w(String::new());
    }
    for object in od.objects() {
        object_sections(od, object, &mut w);
    }
    out
}

fn object_sections(od: &ObjectDictionary, object: &Object, w: &mut impl FnMut(String)) {
    let entries = od.object_entries(object);
    match object.kind {
        ObjectKind::Var => {
            if let Some(e) = entries.first() {
                w(format!("[{:04X}]", object.index));
                entry_keys(&object.name, e, w);
            }
        }
        ObjectKind::Array | ObjectKind::Record => {
            w(format!("[{:04X}]", object.index));
            w(format!("ParameterName={}", clean(&object.name)));
            w(format!("ObjectType=0x{:X}", object.kind.code()));
            w(format!("SubNumber={}", entries.len()));
            w(String::new());
            for e in entries {
                w(format!("[{:04X}sub{:X}]", object.index, e.id.sub));
                entry_keys(e.name, e, w);
            }
        }
    }
}

fn entry_keys(name: &str, e: &Entry, w: &mut impl FnMut(String)) {
    w(format!("ParameterName={}", clean(name)));
    w(format!("ObjectType=0x{:X}", ObjectKind::Var.code()));
    w(format!("DataType=0x{:04X}", e.data_type.code()));
    w(format!("AccessType={}", access_type(e.access)));
    w(format!("DefaultValue={}", eds_value(&e.default)));
    if let Some(min) = &e.min {
        w(format!("LowLimit={}", eds_value(min)));
    }
    if let Some(max) = &e.max {
        w(format!("HighLimit={}", eds_value(max)));
    }
    w(format!("PDOMapping={}", u8::from(e.pdo_mappable)));
    if !e.unit.is_empty() {
        w(format!("Unit={}", clean(e.unit)));
    }
    let mut description = e.description.to_string();
    if e.access == Access::ReadWritePreOperational {
        if !description.is_empty() {
            description.push_str(", ");
        }
        description.push_str("writable in pre-operational only");
    }
    if !description.is_empty() {
        w(format!("Description={}", clean(&description)));
    }
    w(String::new());
}

/// CiA 306 `AccessType` of an access.
pub fn access_type(access: Access) -> &'static str {
    match access {
        Access::ReadOnly => "ro",
        Access::ReadWrite | Access::ReadWritePreOperational => "rw",
        Access::WriteOnly => "wo",
    }
}

/// A value in EDS notation: integers in decimal, booleans 0/1, reals as decimal floats, strings
/// verbatim.
fn eds_value(v: &Value) -> String {
    match v {
        Value::Boolean(b) => u8::from(*b).to_string(),
        Value::VisibleString(s) => clean(s.as_str()),
        other => other.to_string(),
    }
}

/// Keep a value on one line and out of INI comment syntax.
fn clean(text: &str) -> String {
    text.replace(['\r', '\n'], " ").replace(';', ",")
}
