"""The board model: synthetic boards as plain data (`board`), their KiCad files
(`kicad_writer`), D1's Connector arrays (`connector`) and a built set's manifest (`manifest`)."""
