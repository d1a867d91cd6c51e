import { element, setText } from './dom.js';

// server/cell/robot.py UNIT_SCALE: a node unit -> SI factor.
const UNIT_TO_SI = { deg: Math.PI / 180, rad: 1, mm: 0.001, m: 1 };

/** The node value that stands for SI `value` under `joint`'s mapping (Joint.from_si). */
function rawValue( value, joint ) {

	return ( value / UNIT_TO_SI[ joint.source_unit ] - joint.offset ) / joint.scale;

}

/** The mapped value in the node's unit: what `unit` says the node means, after scale and offset. */
function mappedValue( value, joint ) {

	return value / UNIT_TO_SI[ joint.source_unit ];

}

function number( value, digits = 3 ) {

	return Number.isFinite( value ) ? value.toFixed( digits ) : '—';

}

/**
 * A "Mapping" table in each robot card, for commissioning: per joint, the node
 * it reads (and its setpoint node), the raw value the node gave, the scale and
 * offset applied, and the value that makes in the node's unit. Raw values come
 * from the SI joints of the newest frame through the inverse of the mapping, so
 * the frames on the wire stay as they are.
 */
class MappingTables {

	constructor( root, decorate = null ) {

		this.root = root;
		this.decorate = decorate; // ( robot, rows ) => void: a table built (mapping_edit.js)
		this._tables = new Map(); // robot name -> { robot, rows }

	}

	/** Build one table per robot of `hello`, in its card (`#robots [data-robot]`). */
	setHello( hello ) {

		this._tables = new Map();
		for ( const robot of hello.robots ) {

			const card = this.root.querySelector( `#robots [data-robot="${CSS.escape( robot.name )}"]` );
			if ( ! card ) continue;
			const details = element( 'details', 'mapping' );
			details.append( element( 'summary', null, 'Mapping' ) );
			const table = element( 'table', 'mapping-table' );
			table.setAttribute( 'aria-label', `node mapping of ${robot.name}` );
			const head = element( 'tr' );
			for ( const title of [ 'joint', 'raw', '× scale', '+ offset', '= value' ] ) head.append( element( 'th', null, title ) );
			table.append( head );
			// Two rows per joint: the numbers, then the node (long addresses get a line of their own).
			const rows = robot.joints.map( ( joint ) => {

				const row = element( 'tr', 'numbers' );
				row.dataset.joint = joint.name;
				const raw = element( 'td', 'raw', '—' );
				const value = element( 'td', 'value', '—' );
				const scale = element( 'td', 'scale', String( joint.scale ) );
				const offset = element( 'td', 'offset', String( joint.offset ) );
				row.append( element( 'td', 'name', joint.name ), raw, scale, offset, value );
				const where = element( 'tr', 'nodes' );
				const node = element( 'td', 'node' );
				node.colSpan = 5;
				node.append( element( 'code', null, joint.node ) );
				if ( joint.setpoint ) node.append( element( 'div', 'muted', `setpoint ${joint.setpoint}` ) );
				where.append( node );
				table.append( row, where );
				return { joint, raw, value, scale, offset, where };

			} );
			details.append( table );
			card.append( details );
			this._tables.set( robot.name, { robot, rows } );
			this.decorate?.( robot, rows );

		}

	}

	/** Show the raw values of each robot's newest frame (`views`: name -> RobotView). */
	update( views ) {

		for ( const [ name, table ] of this._tables ) {

			const frame = views.get( name )?.lastFrame ?? null;
			const joints = frame && frame.joints.length === table.rows.length ? frame.joints : null;
			table.rows.forEach( ( row, i ) => {

				const si = joints ? joints[ i ] : NaN;
				setText( row.raw, number( rawValue( si, row.joint ) ) );
				setText( row.value, joints ? `${number( mappedValue( si, row.joint ) )} ${row.joint.source_unit}` : '—' );

			} );

		}

	}

	/** What a robot's table shows: per joint { joint, node, setpoint, raw, scale, offset, value }. */
	shown( name ) {

		const table = this._tables.get( name );
		if ( ! table ) return null;
		return table.rows.map( ( row ) => ( {
			joint: row.joint.name, node: row.joint.node, setpoint: row.joint.setpoint ?? null,
			unit: row.joint.source_unit, scale: row.joint.scale, offset: row.joint.offset,
			raw: row.raw.textContent, value: row.value.textContent,
		} ) );

	}

}

export { MappingTables, rawValue };
