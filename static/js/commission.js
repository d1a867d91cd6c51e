import * as THREE from 'three';
import { Calibration } from './calibrate.js';
import { CellEdits } from './cell_edits.js';
import { DescriptionPicker } from './describe.js';
import { button, checkbox, element, setText } from './dom.js';
import { MappingEditor } from './mapping_edit.js';
import { quaternionFromRpy, rpyFromQuaternion } from './rpy.js';
import { RAD_TO_DEG, fixed } from './units.js';

const PLACE_FIELDS = [ [ 'x', 'mm' ], [ 'y', 'mm' ], [ 'z', 'mm' ], [ 'roll', '°' ], [ 'pitch', '°' ], [ 'yaw', '°' ] ];
const _q = new THREE.Quaternion();

/**
 * Commissioning from the page (docs/commissioning.md), for the robot chosen in
 * the right panel: where it stands (typed, or dragged with a gizmo), calibrating
 * an axis or its base from TCP samples, picking its description; every robot's
 * Mapping table made editable; and the cell's unsaved changes, their diff, save
 * and undo. Every change goes to the server, which runs it at once and writes it
 * only when saved, and only with --allow-edits.
 */
class Commissioning {

	constructor( root, stage ) {

		this.stage = stage;
		this.view = null;
		this.views = new Map();
		this.section = root.getElementById( 'commission' );
		this.edits = new CellEdits( this.section );
		this.mapping = new MappingEditor( this.edits );

		this.place = element( 'fieldset', 'place' );
		this.placeLegend = element( 'legend', null, 'Place' );
		const grid = element( 'div', 'target-grid' );
		this.inputs = {};
		// Fields typed into and not yet placed: a hello (another edit's reload, which a busy
		// server may send while the user types) must not put the old numbers back.
		this._typed = new Set();
		for ( const [ key, unit ] of PLACE_FIELDS ) {

			const label = element( 'label' );
			const input = this.edits.guard( element( 'input' ) );
			input.type = 'number';
			input.step = 'any';
			input.setAttribute( 'aria-label', `base ${key} in ${unit === 'mm' ? 'mm' : 'degrees'}` );
			input.addEventListener( 'input', () => this._typed.add( key ) );
			label.append( `${key} `, input, ` ${unit}` );
			grid.append( label );
			this.inputs[ key ] = input;

		}
		this.placeButton = this.edits.guard( button( 'Place', 'place the robot\'s base at these numbers', 'btn btn-primary' ) );
		this.gizmoBox = checkbox( 'gizmo', false, 'move the robot\'s base with a gizmo in the view' );
		this.edits.guard( this.gizmoBox.input );
		this.gizmoMode = element( 'select' );
		this.gizmoMode.setAttribute( 'aria-label', 'base gizmo mode' );
		this.gizmoMode.append( new Option( 'move', 'translate' ), new Option( 'turn', 'rotate' ) );
		const tools = element( 'div', 'toolbar' );
		tools.append( this.placeButton, this.gizmoBox.label, this.gizmoMode );
		this.place.append( this.placeLegend, grid, tools );
		this.section.append( this.place );

		this.calibration = new Calibration( this.section, stage, this.edits );
		this.describe = new DescriptionPicker( this.section, stage, this.edits );

		( { controls: this.gizmo, helper: this.gizmoHelper } = stage.gizmo( 0.9, () => this._placeFromGroup() ) );
		this.gizmo.addEventListener( 'objectChange', () => {

			this._typed.clear(); // the gizmo says where the robot is now
			this._fieldsFrom( this.gizmo.object );

		} );
		this.placeButton.addEventListener( 'click', () => this.placeAtFields() );
		this.gizmoBox.input.addEventListener( 'change', () => this._showGizmo() );
		this.gizmoMode.addEventListener( 'change', () => this.gizmo.setMode( this.gizmoMode.value ) );
		this.edits.onChange( () => this._showGizmo() );
		this.setRobot( null, this.views );

	}

	/** A new hello: another robot list, or the same robots changed (by an edit, a reload). */
	setHello() {

		this.edits.refresh();

	}

	/** Commission `view` (a RobotView, or null); `views` are every robot by name. */
	setRobot( view, views ) {

		const same = view !== null && this.view !== null && view.name === this.view.name;
		if ( ! same ) this._typed.clear();
		this.view = view;
		this.views = views;
		this.place.hidden = view === null;
		this.calibration.setRobot( view, views );
		this.describe.setRobot( view );
		if ( view === null ) return this._showGizmo();
		setText( this.placeLegend, `Place ${view.name}` );
		this._fieldsFrom( view.group );
		this._showGizmo();

	}

	/** The fields from `object`'s pose, but for those typed into and not yet placed. */
	_fieldsFrom( object ) {

		const { position, quaternion } = object;
		const rpy = rpyFromQuaternion( quaternion.x, quaternion.y, quaternion.z, quaternion.w );
		const values = [ ...position.toArray().map( ( v ) => v * 1000 ), ...rpy.map( ( a ) => a * RAD_TO_DEG ) ];
		PLACE_FIELDS.forEach( ( [ key ], i ) => {

			if ( ! this._typed.has( key ) ) this.inputs[ key ].value = fixed( values[ i ], 3 );

		} );

	}

	/** Place the robot where the fields say (mm and degrees on screen, SI to the server). */
	placeAtFields() {

		const values = PLACE_FIELDS.map( ( [ key ] ) => Number( this.inputs[ key ].value ) );
		if ( ! this.view || ! values.every( Number.isFinite ) ) return;
		this._typed.clear();
		return this._placeBase( values.slice( 0, 3 ).map( ( v ) => v / 1000 ), values.slice( 3 ).map( ( a ) => a / RAD_TO_DEG ) );

	}

	_placeFromGroup() {

		const group = this.gizmo.object;
		if ( ! group || ! this.view ) return;
		const { x, y, z, w } = _q.copy( group.quaternion ).normalize();
		this._placeBase( group.position.toArray(), rpyFromQuaternion( x, y, z, w ) );

	}

	_placeBase( xyz, rpy ) {

		return this.edits.change( [ { op: 'base', robot: this.view.name, xyz, rpy } ] );

	}

	_showGizmo() {

		const on = this.gizmoBox.input.checked && this.view !== null && this.edits.editable;
		if ( on && this.gizmo.object !== this.view.group ) this.gizmo.attach( this.view.group );
		if ( ! on ) this.gizmo.detach();
		this.gizmoHelper.visible = on;

	}

	/** Whether the fields round-trip to the quaternion of the base shown (tests). */
	fieldQuaternion() {

		const [ roll, pitch, yaw ] = [ 'roll', 'pitch', 'yaw' ].map( ( key ) => Number( this.inputs[ key ].value ) / RAD_TO_DEG );
		return quaternionFromRpy( roll, pitch, yaw );

	}

	/** Everything commissioning shows (tests and the console). */
	shown() {

		const controls = [ ...this.section.ownerDocument.querySelectorAll( '[data-edit]' ) ];
		return {
			robot: this.view?.name ?? null,
			edits: this.edits.shown(),
			place: Object.fromEntries( PLACE_FIELDS.map( ( [ key ] ) => [ key, this.inputs[ key ].value ] ) ),
			calibration: this.calibration.shown(),
			describe: this.describe.shown(),
			controls: controls.map( ( el ) => ( { label: el.getAttribute( 'aria-label' ) ?? el.textContent, disabled: el.disabled, title: el.title } ) ),
			gizmo: this.gizmoHelper.visible ? this.gizmo.object?.name ?? null : null,
			gizmoAxis: this.gizmo.axis, // the handle under the pointer ('X', 'XY', ...), or null
		};

	}

	dispose() {

		this.gizmo.detach();
		this.gizmo.dispose();
		this.gizmoHelper.removeFromParent();
		this.calibration.dispose();
		this.describe.dispose();

	}

}

export { Commissioning };
