import { button, element } from './dom.js';
import { displayScale, displayUnit } from './units.js';

// Node units a joint may read in (server/cell/load.py: rotary deg or rad, linear mm or m).
const UNITS = { rad: [ 'deg', 'rad' ], m: [ 'mm', 'm' ] };

function numberInput( value, label ) {

	const input = element( 'input', 'mapping-number' );
	input.type = 'number';
	input.step = 'any';
	input.value = String( value );
	input.setAttribute( 'aria-label', label );
	return input;

}

/**
 * Makes each Mapping table (mapping.js) editable: a joint's scale and offset
 * typed in place, its sign flipped, its node unit chosen, or "it reads X now"
 * (the offset that makes the value it reads now X). Each change runs on the
 * server at once (the model moves) and is saved with the cell (cell_edits.js).
 */
class MappingEditor {

	constructor( edits ) {

		this.edits = edits; // CellEdits
		this.decorate = ( robot, rows ) => this._decorate( robot, rows );

	}

	_decorate( robot, rows ) {

		this.edits.prune();
		for ( const row of rows ) {

			const { joint } = row;
			const who = `${joint.name} of ${robot.name}`;
			const scale = this._guard( numberInput( joint.scale, `scale of ${who}` ) );
			scale.addEventListener( 'change', () => this._set( robot.name, joint.name, { scale: Number( scale.value ) } ) );
			row.scale.replaceChildren( scale );
			const offset = this._guard( numberInput( joint.offset, `offset of ${who} (${joint.source_unit})` ) );
			offset.addEventListener( 'change', () => this._set( robot.name, joint.name, { offset: Number( offset.value ) } ) );
			row.offset.replaceChildren( offset );

			const tools = element( 'div', 'mapping-edit' );
			const flip = this._guard( button( '±', `flip the sign of ${who}`, 'btn btn-small' ) );
			flip.addEventListener( 'click', () => this._set( robot.name, joint.name, { scale: - joint.scale } ) );
			const unit = this._guard( element( 'select' ) );
			unit.setAttribute( 'aria-label', `node unit of ${who}` );
			for ( const name of UNITS[ joint.unit ] ) unit.append( new Option( name, name, false, name === joint.source_unit ) );
			unit.addEventListener( 'change', () => this._set( robot.name, joint.name, { unit: unit.value } ) );
			const reads = this._guard( numberInput( '', `value ${who} reads now, in ${displayUnit( joint )}` ) );
			reads.placeholder = `now, ${displayUnit( joint )}`;
			const set = this._guard( button( 'reads now', `make ${who} read the typed value now`, 'btn btn-small' ) );
			set.addEventListener( 'click', () => {

				const typed = Number( reads.value );
				if ( reads.value === '' || ! Number.isFinite( typed ) ) return;
				this._change( { op: 'joint_reads', robot: robot.name, joint: joint.name, value: typed / displayScale( joint ) } );

			} );
			tools.append( flip, unit, reads, set );
			row.where.firstChild.append( tools );

		}

	}

	_guard( control ) {

		return this.edits.guard( control );

	}

	_set( robotName, jointName, keys ) {

		if ( Object.values( keys ).some( ( v ) => typeof v === 'number' && ! Number.isFinite( v ) ) ) return;
		return this._change( { op: 'joint', robot: robotName, joint: jointName, ...keys } );

	}

	_change( change ) {

		return this.edits.change( [ change ] );

	}

}

export { MappingEditor };
