//! One Parquet table written a row group at a time, through the `parquet` crate's column
//! writers (no Arrow layer: a dataset's tables are a few fixed columns, and the values go from
//! the frame buffers to the pages without an intermediate array per row).
//!
//! Columns are declared once ([`Column`]); rows are appended into per-column buffers, and each
//! time the buffered rows reach the group's size in bytes they are written out as one row group
//! and the buffers are reused: memory holds one row group, whatever the input's length.
//!
//! Lists are Parquet's standard three-level `LIST` (`optional group NAME (LIST) { repeated
//! group list { required ELEMENT element; } }`), which pyarrow, HF `datasets` and Ray read as
//! `list<element>`.

use parquet::basic::{Compression, ConvertedType, LogicalType, Repetition, Type as Physical};
use parquet::data_type::{BoolType, ByteArray, ByteArrayType, DoubleType, FloatType, Int64Type};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::{EnabledStatistics, WriterProperties, WriterVersion};
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::{ColumnPath, Type, TypePtr};
use std::io::Write;
use std::sync::Arc;

/// What one column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    I64,
    F64,
    Bool,
    /// UTF-8 text.
    Str,
    /// Text or null.
    OptStr,
    /// An integer or null.
    OptI64,
    /// A number or null.
    OptF64,
    /// A list of float32 (a link's readings).
    ListF32,
    /// A list of text.
    ListStr,
    /// float32 (a frame's time, as LeRobot stores it).
    F32,
}

/// A column: its name and kind.
#[derive(Debug, Clone)]
pub(crate) struct Column {
    pub name: String,
    pub kind: Kind,
}

impl Column {
    pub fn new(name: impl Into<String>, kind: Kind) -> Column {
        Column {
            name: name.into(),
            kind,
        }
    }

    /// A table's fixed columns, by name and kind.
    pub fn list(columns: &[(&str, Kind)]) -> Vec<Column> {
        columns.iter().map(|&(n, k)| Column::new(n, k)).collect()
    }
}

/// One column's buffered values of the row group being built.
#[derive(Debug)]
enum Buf {
    I64(Vec<i64>),
    F32(Vec<f32>),
    F64(Vec<f64>),
    Bool(Vec<bool>),
    Str(Vec<ByteArray>),
    OptStr(Vec<ByteArray>, Vec<i16>),
    OptI64(Vec<i64>, Vec<i16>),
    OptF64(Vec<f64>, Vec<i16>),
    /// Values, and each row's length.
    ListF32(Vec<f32>, Vec<u32>),
    ListStr(Vec<ByteArray>, Vec<u32>),
}

impl Buf {
    fn new(kind: Kind) -> Buf {
        match kind {
            Kind::I64 => Buf::I64(Vec::new()),
            Kind::F32 => Buf::F32(Vec::new()),
            Kind::F64 => Buf::F64(Vec::new()),
            Kind::Bool => Buf::Bool(Vec::new()),
            Kind::Str => Buf::Str(Vec::new()),
            Kind::OptStr => Buf::OptStr(Vec::new(), Vec::new()),
            Kind::OptI64 => Buf::OptI64(Vec::new(), Vec::new()),
            Kind::OptF64 => Buf::OptF64(Vec::new(), Vec::new()),
            Kind::ListF32 => Buf::ListF32(Vec::new(), Vec::new()),
            Kind::ListStr => Buf::ListStr(Vec::new(), Vec::new()),
        }
    }

    fn clear(&mut self) {
        match self {
            Buf::I64(v) | Buf::OptI64(v, _) => v.clear(),
            Buf::F32(v) | Buf::ListF32(v, _) => v.clear(),
            Buf::F64(v) | Buf::OptF64(v, _) => v.clear(),
            Buf::Bool(v) => v.clear(),
            Buf::Str(v) | Buf::OptStr(v, _) | Buf::ListStr(v, _) => v.clear(),
        }
        match self {
            Buf::OptStr(_, d) | Buf::OptI64(_, d) | Buf::OptF64(_, d) => d.clear(),
            Buf::ListF32(_, n) | Buf::ListStr(_, n) => n.clear(),
            _ => {}
        }
    }
}

/// A value handed to [`Table::push`] for one column of a row.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Value<'a> {
    I64(i64),
    F32(f32),
    F64(f64),
    Bool(bool),
    Str(&'a str),
    OptStr(Option<&'a str>),
    OptI64(Option<i64>),
    OptF64(Option<f64>),
    ListF32(&'a [f32]),
    ListStr(&'a [String]),
}

/// A row's value does not fit its column (a bug of the caller: columns are fixed per table).
#[derive(Debug, thiserror::Error)]
#[error("column {column}: a {got} value where the table holds {expected:?}")]
pub struct ColumnMismatch {
    column: String,
    got: &'static str,
    expected: Kind,
}

/// What a table's writing fails with.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    /// Parquet refused the schema or a write (the file's own I/O included).
    #[error(transparent)]
    Parquet(#[from] parquet::errors::ParquetError),
    /// A row's value of the wrong kind.
    #[error(transparent)]
    Mismatch(#[from] ColumnMismatch),
}

/// Bytes of buffered values after which a row group is written.
const GROUP_BYTES: usize = 32 << 20;

/// A Parquet file being written, a row group at a time.
pub(crate) struct Table<W: Write + Send> {
    writer: SerializedFileWriter<W>,
    columns: Vec<Column>,
    bufs: Vec<Buf>,
    rows: usize,
    bytes: usize,
    /// Definition and repetition levels of a list column, reused between row groups.
    def: Vec<i16>,
    rep: Vec<i16>,
}

impl<W: Write + Send> std::fmt::Debug for Table<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Table")
            .field("columns", &self.columns.len())
            .field("rows", &self.rows)
            .finish_non_exhaustive()
    }
}

fn primitive(name: &str, physical: Physical, repetition: Repetition) -> parquet::errors::Result<TypePtr> {
    let mut b = Type::primitive_type_builder(name, physical).with_repetition(repetition);
    if physical == Physical::BYTE_ARRAY {
        b = b.with_logical_type(Some(LogicalType::String));
    }
    Ok(Arc::new(b.build()?))
}

/// `optional group NAME (LIST) { repeated group list { required ELEMENT element; } }`.
fn list(name: &str, element: Physical) -> parquet::errors::Result<TypePtr> {
    let item = primitive("element", element, Repetition::REQUIRED)?;
    let repeated = Type::group_type_builder("list")
        .with_repetition(Repetition::REPEATED)
        .with_fields(vec![item])
        .build()?;
    Ok(Arc::new(
        Type::group_type_builder(name)
            .with_repetition(Repetition::OPTIONAL)
            .with_converted_type(ConvertedType::LIST)
            .with_logical_type(Some(LogicalType::List))
            .with_fields(vec![Arc::new(repeated)])
            .build()?,
    ))
}

fn schema(columns: &[Column]) -> parquet::errors::Result<TypePtr> {
    const OPTIONAL: Repetition = Repetition::OPTIONAL;
    const REQUIRED: Repetition = Repetition::REQUIRED;
    let fields = columns
        .iter()
        .map(|c| match c.kind {
            Kind::I64 => primitive(&c.name, Physical::INT64, REQUIRED),
            Kind::F32 => primitive(&c.name, Physical::FLOAT, REQUIRED),
            Kind::F64 => primitive(&c.name, Physical::DOUBLE, REQUIRED),
            Kind::Bool => primitive(&c.name, Physical::BOOLEAN, REQUIRED),
            Kind::Str => primitive(&c.name, Physical::BYTE_ARRAY, REQUIRED),
            Kind::OptStr => primitive(&c.name, Physical::BYTE_ARRAY, OPTIONAL),
            Kind::OptI64 => primitive(&c.name, Physical::INT64, OPTIONAL),
            Kind::OptF64 => primitive(&c.name, Physical::DOUBLE, OPTIONAL),
            Kind::ListF32 => list(&c.name, Physical::FLOAT),
            Kind::ListStr => list(&c.name, Physical::BYTE_ARRAY),
        })
        .collect::<parquet::errors::Result<Vec<_>>>()?;
    Ok(Arc::new(
        Type::group_type_builder("schema").with_fields(fields).build()?,
    ))
}

/// Snappy (what pyarrow and LeRobot write), no dictionaries (readings rarely repeat within a
/// page, and hashing each value would cost more than the page it saves); no statistics on the
/// reading lists (min / max of every taxel's column is not what a reader filters on).
fn properties(columns: &[Column], metadata: Vec<KeyValue>) -> WriterProperties {
    let mut p = WriterProperties::builder()
        .set_writer_version(WriterVersion::PARQUET_1_0)
        .set_compression(Compression::SNAPPY)
        .set_dictionary_enabled(false)
        .set_created_by(format!("skin {}", env!("CARGO_PKG_VERSION")))
        .set_key_value_metadata((!metadata.is_empty()).then_some(metadata));
    for c in columns.iter().filter(|c| c.kind == Kind::ListF32) {
        let path = ColumnPath::new(vec![c.name.clone(), "list".into(), "element".into()]);
        p = p.set_column_statistics_enabled(path, EnabledStatistics::None);
    }
    p.build()
}

impl<W: Write + Send> Table<W> {
    /// A table of `columns` written to `out`, with the file's key-value `metadata`.
    pub fn new(out: W, columns: Vec<Column>, metadata: Vec<KeyValue>) -> Result<Table<W>, TableError> {
        let props = Arc::new(properties(&columns, metadata));
        let writer = SerializedFileWriter::new(out, schema(&columns)?, props)?;
        Ok(Table {
            writer,
            bufs: columns.iter().map(|c| Buf::new(c.kind)).collect(),
            columns,
            rows: 0,
            bytes: 0,
            def: Vec::new(),
            rep: Vec::new(),
        })
    }

    /// Appends one row: a value per column, in the columns' order.
    pub fn push(&mut self, row: &[Value<'_>]) -> Result<(), TableError> {
        debug_assert_eq!(row.len(), self.bufs.len());
        for ((buf, value), column) in self.bufs.iter_mut().zip(row).zip(&self.columns) {
            self.bytes += put(buf, *value, column)?;
        }
        self.rows += 1;
        if self.bytes >= GROUP_BYTES {
            self.flush()?;
        }
        Ok(())
    }

    /// Writes the buffered rows as one row group.
    fn flush(&mut self) -> Result<(), TableError> {
        if self.bufs.first().is_none_or(|b| group_rows(b) == 0) {
            return Ok(());
        }
        let mut group = self.writer.next_row_group()?;
        for buf in &mut self.bufs {
            let Some(mut col) = group.next_column()? else {
                break;
            };
            write_column(&mut col, buf, &mut self.def, &mut self.rep)?;
            col.close()?;
            buf.clear();
        }
        group.close()?;
        self.bytes = 0;
        Ok(())
    }

    /// The last row group and the footer: the file is whole once this returns.
    pub fn finish(mut self) -> Result<W, TableError> {
        self.flush()?;
        Ok(self.writer.into_inner()?)
    }
}

/// Rows buffered in a column.
fn group_rows(buf: &Buf) -> usize {
    match buf {
        Buf::I64(v) => v.len(),
        Buf::F32(v) => v.len(),
        Buf::F64(v) => v.len(),
        Buf::Bool(v) => v.len(),
        Buf::Str(v) => v.len(),
        Buf::OptStr(_, d) | Buf::OptI64(_, d) | Buf::OptF64(_, d) => d.len(),
        Buf::ListF32(_, n) | Buf::ListStr(_, n) => n.len(),
    }
}

/// Buffers one value; returns the bytes it takes.
fn put(buf: &mut Buf, value: Value<'_>, column: &Column) -> Result<usize, ColumnMismatch> {
    let opt = |d: &mut Vec<i16>, some: bool| d.push(i16::from(some));
    Ok(match (buf, value) {
        (Buf::I64(v), Value::I64(x)) => {
            v.push(x);
            8
        }
        (Buf::F32(v), Value::F32(x)) => {
            v.push(x);
            4
        }
        (Buf::F64(v), Value::F64(x)) => {
            v.push(x);
            8
        }
        (Buf::Bool(v), Value::Bool(x)) => {
            v.push(x);
            1
        }
        (Buf::Str(v), Value::Str(s)) => {
            v.push(ByteArray::from(s));
            s.len() + 4
        }
        (Buf::OptStr(v, d), Value::OptStr(s)) => {
            opt(d, s.is_some());
            v.extend(s.map(ByteArray::from));
            s.map_or(0, str::len) + 4
        }
        (Buf::OptI64(v, d), Value::OptI64(x)) => {
            opt(d, x.is_some());
            v.extend(x);
            8
        }
        (Buf::OptF64(v, d), Value::OptF64(x)) => {
            opt(d, x.is_some());
            v.extend(x);
            8
        }
        (Buf::ListF32(v, n), Value::ListF32(xs)) => {
            v.extend_from_slice(xs);
            n.push(u32::try_from(xs.len()).unwrap_or(u32::MAX));
            xs.len() * 4 + 4
        }
        (Buf::ListStr(v, n), Value::ListStr(xs)) => {
            v.extend(xs.iter().map(|s| ByteArray::from(s.as_str())));
            n.push(u32::try_from(xs.len()).unwrap_or(u32::MAX));
            xs.iter().map(|s| s.len() + 4).sum::<usize>() + 4
        }
        (_, value) => {
            return Err(ColumnMismatch {
                column: column.name.clone(),
                got: value_name(value),
                expected: column.kind,
            });
        }
    })
}

fn value_name(value: Value<'_>) -> &'static str {
    match value {
        Value::I64(_) => "int64",
        Value::F32(_) => "float32",
        Value::F64(_) => "float64",
        Value::Bool(_) => "bool",
        Value::Str(_) => "text",
        Value::OptStr(_) => "optional text",
        Value::OptI64(_) => "optional int64",
        Value::OptF64(_) => "optional float64",
        Value::ListF32(_) => "float32 list",
        Value::ListStr(_) => "text list",
    }
}

/// A list column's levels for rows of `lengths`: an empty list is one level 1 with no value,
/// each element a level 2; the first element of a row repeats at level 0.
fn list_levels(lengths: &[u32], def: &mut Vec<i16>, rep: &mut Vec<i16>) {
    def.clear();
    rep.clear();
    for &n in lengths {
        if n == 0 {
            def.push(1);
            rep.push(0);
        } else {
            let n = n as usize;
            def.resize(def.len() + n, 2);
            rep.push(0);
            rep.resize(rep.len() + n - 1, 1);
        }
    }
}

fn write_column(
    col: &mut parquet::file::writer::SerializedColumnWriter<'_>,
    buf: &Buf,
    def: &mut Vec<i16>,
    rep: &mut Vec<i16>,
) -> parquet::errors::Result<()> {
    match buf {
        Buf::I64(v) => col.typed::<Int64Type>().write_batch(v, None, None)?,
        Buf::F32(v) => col.typed::<FloatType>().write_batch(v, None, None)?,
        Buf::F64(v) => col.typed::<DoubleType>().write_batch(v, None, None)?,
        Buf::Bool(v) => col.typed::<BoolType>().write_batch(v, None, None)?,
        Buf::Str(v) => col.typed::<ByteArrayType>().write_batch(v, None, None)?,
        Buf::OptStr(v, d) => col.typed::<ByteArrayType>().write_batch(v, Some(d), None)?,
        Buf::OptI64(v, d) => col.typed::<Int64Type>().write_batch(v, Some(d), None)?,
        Buf::OptF64(v, d) => col.typed::<DoubleType>().write_batch(v, Some(d), None)?,
        Buf::ListF32(v, n) => {
            list_levels(n, def, rep);
            col.typed::<FloatType>().write_batch(v, Some(def), Some(rep))?
        }
        Buf::ListStr(v, n) => {
            list_levels(n, def, rep);
            col.typed::<ByteArrayType>()
                .write_batch(v, Some(def), Some(rep))?
        }
    };
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::panic)]
    use super::*;
    use parquet::file::reader::{FileReader, SerializedFileReader};
    use parquet::record::Field;

    fn columns() -> Vec<Column> {
        vec![
            Column::new("i", Kind::I64),
            Column::new("name", Kind::OptStr),
            Column::new("x.readings", Kind::ListF32),
        ]
    }

    /// What parquet's own reader finds in a file this writer wrote, row by row.
    fn read(bytes: Vec<u8>) -> Vec<Vec<(String, Field)>> {
        let reader = SerializedFileReader::new(bytes::Bytes::from(bytes)).unwrap();
        reader
            .get_row_iter(None)
            .unwrap()
            .map(|r| {
                r.unwrap()
                    .get_column_iter()
                    .map(|(k, v)| (k.clone(), v.clone()))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn rows_come_back_as_written_with_nulls_and_empty_lists() {
        let mut t = Table::new(Vec::new(), columns(), Vec::new()).unwrap();
        t.push(&[
            Value::I64(7),
            Value::OptStr(Some("a")),
            Value::ListF32(&[1.5, -0.0, f32::MAX]),
        ])
        .unwrap();
        t.push(&[Value::I64(-1), Value::OptStr(None), Value::ListF32(&[])])
            .unwrap();
        let rows = read(t.finish().unwrap());
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[0][0].1, Field::Long(7));
        assert_eq!(rows[0][1].1, Field::Str("a".into()));
        let Field::ListInternal(list) = &rows[0][2].1 else {
            panic!("{:?}", rows[0][2])
        };
        let got: Vec<u32> = list
            .elements()
            .iter()
            .map(|f| match f {
                Field::Float(x) => x.to_bits(),
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(got, [1.5f32.to_bits(), (-0.0f32).to_bits(), f32::MAX.to_bits()]);
        assert_eq!(rows[1][1].1, Field::Null);
        let Field::ListInternal(list) = &rows[1][2].1 else {
            panic!()
        };
        assert!(list.elements().is_empty());
    }

    proptest::proptest! {
        /// Any floats (NaN payloads, infinities, -0.0, subnormals), any list lengths (empty
        /// ones too), any text or none: each row back bit for bit, in order.
        #[test]
        fn any_rows_come_back_bit_for_bit(
            rows in proptest::collection::vec(
                (proptest::collection::vec(proptest::num::f32::ANY, 0..40), proptest::option::of("[a-z\\u{e9}\\u{1F600}]{0,5}")),
                1..30,
            )
        ) {
            let mut t = Table::new(Vec::new(), columns(), Vec::new()).unwrap();
            for (i, (values, name)) in rows.iter().enumerate() {
                t.push(&[Value::I64(i as i64), Value::OptStr(name.as_deref()), Value::ListF32(values)]).unwrap();
            }
            let back = read(t.finish().unwrap());
            proptest::prop_assert_eq!(back.len(), rows.len());
            for (row, (values, name)) in back.iter().zip(&rows) {
                let Field::ListInternal(list) = &row[2].1 else { panic!() };
                let got: Vec<u32> = list.elements().iter().map(|f| match f {
                    Field::Float(x) => x.to_bits(),
                    other => panic!("{other:?}"),
                }).collect();
                let want: Vec<u32> = values.iter().map(|v| v.to_bits()).collect();
                proptest::prop_assert_eq!(got, want);
                let want_name = name.clone().map_or(Field::Null, Field::Str);
                proptest::prop_assert_eq!(&row[1].1, &want_name);
            }
        }
    }

    #[test]
    fn a_wrong_value_names_its_column() {
        let mut t = Table::new(Vec::new(), columns(), Vec::new()).unwrap();
        let e = t
            .push(&[Value::Str("no"), Value::OptStr(None), Value::ListF32(&[])])
            .unwrap_err();
        assert!(e.to_string().contains("column i: a text value"), "{e}");
    }

    #[test]
    fn many_row_groups_keep_every_row_in_order() {
        // Rows of 1 MB: a row group every 32 of them.
        let big = vec![0.25f32; 1 << 18];
        let mut t = Table::new(Vec::new(), columns(), Vec::new()).unwrap();
        for i in 0..80 {
            t.push(&[
                Value::I64(i),
                Value::OptStr(None),
                Value::ListF32(&big[..(1 << 18) - i as usize]),
            ])
            .unwrap();
        }
        let bytes = t.finish().unwrap();
        let reader = SerializedFileReader::new(bytes::Bytes::from(bytes.clone())).unwrap();
        assert_eq!(reader.metadata().num_row_groups(), 3);
        let rows = read(bytes);
        assert_eq!(rows.len(), 80);
        for (i, row) in rows.iter().enumerate() {
            assert_eq!(row[0].1, Field::Long(i as i64));
            let Field::ListInternal(list) = &row[2].1 else {
                panic!()
            };
            assert_eq!(list.elements().len(), (1 << 18) - i);
        }
    }
}
