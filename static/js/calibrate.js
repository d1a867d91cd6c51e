import * as THREE from 'three';
import { reason } from './api.js';
import { calibrate, sampleTcp } from './commission_api.js';
import { button, checkbox, element, setText } from './dom.js';
import { fixed } from './units.js';

// What each sample is for, as MotionPlus's calibrate_rotary_axis / calibrate_linear_axis take them.
const ROLES = {
	rotary: [ [ 'headstock', 'headstock' ], [ 'tailstock', 'tailstock' ] ],
	linear: [ [ 'origin', 'origin' ], [ 'z', 'z point' ], [ 'x', 'x direction' ] ],
};
const SAMPLE_RADIUS = 0.01; // m
const COLOR = 0xff2d95;

const _m = new THREE.Matrix4();
const _v = new THREE.Vector3();
const _q = new THREE.Quaternion();
const _one = new THREE.Vector3( 1, 1, 1 );

/** 4x4 of a pose [x, y, z, qx, qy, qz, qw] (a robot's base in hello). */
function matrixOf7( pose, target = new THREE.Matrix4() ) {

	return target.compose( _v.fromArray( pose, 0 ), _q.fromArray( pose, 3 ), _one );

}

/** 4x4 of a UR pose vector [x, y, z, rx, ry, rz] (m, rotation vector in rad). */
function matrixOfPoseVector( pose, target = new THREE.Matrix4() ) {

	const axis = new THREE.Vector3( pose[ 3 ], pose[ 4 ], pose[ 5 ] );
	const angle = axis.length();
	const turn = angle > 0 ? new THREE.Quaternion().setFromAxisAngle( axis.divideScalar( angle ), angle ) : new THREE.Quaternion();
	return target.compose( new THREE.Vector3( pose[ 0 ], pose[ 1 ], pose[ 2 ] ), turn, _one );

}

const mm = ( metres ) => fixed( metres * 1000, 3 );

/**
 * Calibrating an external axis (or any robot's base) as Universal Robots'
 * MotionPlus does: a measuring robot's TCP touches points round the axis (a
 * button per sample, from the live values, or typed), the server fits the
 * frame (POST /api/calibrate), the page draws the samples, the fitted circle or
 * line and the frame, with the radius and the errors; Apply makes it the frame
 * of the chosen axis (or of the base) at the joints the robot had at the first
 * sample, by moving the robot's base or by setting the axis's pose in its parent.
 */
class Calibration {

	constructor( container, stage, edits ) {

		this.stage = stage;
		this.edits = edits;
		this.view = null; // the robot being placed
		this.views = new Map();
		this.samples = []; // { role, tcp: [6] (measuring base frame), world: [3], joints (target, SI) }
		this.result = null; // the fit, as POST /api/calibrate answered
		this.drawing = new THREE.Group();
		this.drawing.name = 'calibration';
		stage.world.add( this.drawing );

		this.el = element( 'fieldset', 'calibrate' );
		this.legend = element( 'legend', null, 'Calibrate' );
		this.frameOf = this._select( 'frame calibrated' );
		this.measuring = this._select( 'robot whose TCP takes the samples' );
		this.kind = this._select( 'kind of axis' );
		for ( const kind of [ 'rotary', 'linear' ] ) this.kind.append( new Option( kind, kind ) );
		this.mounted = checkbox( 'robot rides on it', false, 'the measuring robot is mounted on the linear axis' );
		this.role = this._select( 'what the next sample is' );
		this.takeButton = button( 'Take sample', 'take a sample: the measuring robot\'s TCP now' );
		this.typed = [ 'x', 'y', 'z' ].map( ( axis ) => {

			const input = element( 'input', 'typed' );
			input.type = 'number';
			input.step = 'any';
			input.setAttribute( 'aria-label', `typed sample ${axis} in mm, in the measuring robot's base frame` );
			return input;

		} );
		this.addButton = button( 'Add typed', 'add the typed position as a sample' );
		this.list = element( 'ol', 'samples' );
		this.list.setAttribute( 'aria-label', 'calibration samples' );
		this.fitButton = button( 'Fit', 'fit the axis frame to the samples', 'btn btn-primary' );
		this.clearButton = button( 'Clear', 'remove every sample' );
		this.resultEl = element( 'p', 'fit-result' );
		this.resultEl.setAttribute( 'role', 'status' );
		this.setTo = this._select( 'what applying the fit changes' );
		this.applyButton = edits.guard( button( 'Apply', 'make the fitted frame the robot\'s, in the cell', 'btn btn-primary' ) );

		const rows = [
			[ this._labelled( 'frame of', this.frameOf ), this._labelled( 'measured by', this.measuring ) ],
			[ this._labelled( 'axis', this.kind ), this.mounted.label ],
			[ this._labelled( 'next', this.role ), this.takeButton ],
			[ ...this.typed.map( ( input, i ) => this._labelled( 'xyz'[ i ], input ) ), element( 'span', 'muted', 'mm' ), this.addButton ],
		];
		this.el.append( this.legend );
		for ( const row of rows ) {

			const line = element( 'div', 'toolbar' );
			line.append( ...row );
			this.el.append( line );

		}
		const fit = element( 'div', 'toolbar' );
		fit.append( this.fitButton, this.clearButton );
		const apply = element( 'div', 'toolbar' );
		apply.append( this._labelled( 'set', this.setTo ), this.applyButton );
		this.el.append( this.list, fit, this.resultEl, apply );
		container.append( this.el );

		this.kind.addEventListener( 'change', () => this._kindChanged() );
		this.frameOf.addEventListener( 'change', () => {

			this._fillSetTo();
			this._clear(); // samples of another frame

		} );
		this.measuring.addEventListener( 'change', () => this._clear() );
		this.takeButton.addEventListener( 'click', () => this.take() );
		this.addButton.addEventListener( 'click', () => this.addTyped() );
		this.fitButton.addEventListener( 'click', () => this.fit() );
		this.clearButton.addEventListener( 'click', () => this._clear() );
		this.applyButton.addEventListener( 'click', () => this.apply() );
		this._kindChanged();

	}

	_select( label ) {

		const select = element( 'select' );
		select.setAttribute( 'aria-label', label );
		return select;

	}

	_labelled( text, control ) {

		const label = element( 'label', 'field' );
		label.append( `${text} `, control );
		return label;

	}

	/** Calibrate for `view` (null: none); `views` are every robot, any may measure. */
	setRobot( view, views ) {

		const same = view !== null && this.view !== null && view.name === this.view.name;
		this.view = view;
		this.views = views;
		this.el.hidden = view === null;
		if ( view === null ) return this._clear();
		setText( this.legend, `Calibrate ${view.name}` );
		const keepFrame = this.frameOf.value;
		const axes = view.info.kinematics === 'axis_group' ? view.info.params.axes.map( ( axis ) => axis.name ) : [];
		this.frameOf.replaceChildren( new Option( 'robot base', '' ), ...axes.map( ( name ) => new Option( `axis ${name}`, name ) ) );
		if ( same && [ ...this.frameOf.options ].some( ( o ) => o.value === keepFrame ) ) this.frameOf.value = keepFrame;
		else if ( axes.length ) this.frameOf.value = axes[ 0 ];
		const keepMeasuring = this.measuring.value;
		const others = [ ...views.keys() ].filter( ( name ) => name !== view.name );
		this.measuring.replaceChildren( ...others.map( ( name ) => new Option( name, name ) ) );
		if ( others.includes( keepMeasuring ) ) this.measuring.value = keepMeasuring;
		this._fillSetTo();
		if ( ! same ) this._clear();
		else this._draw(); // a new hello: the robots (and the measuring one's base) may have moved

	}

	_fillSetTo() {

		const axis = this.frameOf.value;
		const keep = this.setTo.value;
		const options = [ new Option( `${this.view?.name ?? 'its'} base`, 'base' ) ];
		if ( axis ) options.push( new Option( `axis ${axis}'s pose in its parent`, 'axis' ) );
		this.setTo.replaceChildren( ...options );
		if ( options.some( ( option ) => option.value === keep ) ) this.setTo.value = keep;

	}

	_kindChanged() {

		this.role.replaceChildren( ...ROLES[ this.kind.value ].map( ( [ value, text ] ) => new Option( text, value ) ) );
		this.mounted.label.hidden = this.kind.value !== 'linear';
		this._clear();

	}

	_clear() {

		this.samples = [];
		this.result = null;
		setText( this.resultEl, '' );
		this._render();

	}

	async take() {

		const measuring = this.measuring.value;
		if ( ! this.view || ! measuring ) return this._say( 'Choose the robot that measures.' );
		const [ tcp, own ] = await Promise.all( [ sampleTcp( measuring ), sampleTcp( this.view.name ) ] );
		if ( ! tcp.ok ) return this._say( `No sample: ${reason( tcp )}` );
		this._add( { tcp: tcp.body.tcp, world: tcp.body.world.slice( 0, 3 ), joints: own.ok ? own.body.joints : null } );

	}

	async addTyped() {

		const xyz = this.typed.map( ( input ) => Number( input.value ) / 1000 );
		if ( this.typed.some( ( input ) => input.value === '' ) || ! xyz.every( Number.isFinite ) ) return this._say( 'Type x, y and z (mm).' );
		const base = this.views.get( this.measuring.value );
		if ( ! this.view || ! base ) return this._say( 'Choose the robot that measures.' );
		const world = _v.fromArray( xyz ).applyMatrix4( matrixOf7( base.info.base, _m ) ).toArray();
		const own = await sampleTcp( this.view.name );
		this._add( { tcp: [ ...xyz, 0, 0, 0 ], world, joints: own.ok ? own.body.joints : null } );

	}

	_add( sample ) {

		this.samples.push( { role: this.role.value, ...sample } );
		this.result = null;
		setText( this.resultEl, '' );
		this._render();

	}

	_body() {

		const of = ( role ) => this.samples.filter( ( s ) => s.role === role ).map( ( s ) => s.tcp );
		if ( this.kind.value === 'rotary' ) return { kind: 'rotary', headstock: of( 'headstock' ), tailstock: of( 'tailstock' ) };
		const origin = of( 'origin' ).at( - 1 );
		const towards = of( 'x' ).at( - 1 );
		if ( ! origin || ! towards ) return null;
		return { kind: 'linear', origin, z_points: of( 'z' ), x_dir: towards, is_mounted: this.mounted.input.checked };

	}

	async fit() {

		const body = this._body();
		if ( body === null ) return this._say( 'Refused: a linear axis needs an origin sample and an x direction sample.' );
		const result = await calibrate( body );
		if ( ! result.ok ) {

			this.result = null;
			this._render();
			return this._say( `Refused: ${reason( result )}` );

		}
		this.result = { ...result.body, kind: body.kind, measuring: this.measuring.value };
		const radius = result.body.radius === undefined ? '' : `radius ${mm( result.body.radius )} mm · `;
		this._say( `${radius}max error ${mm( result.body.max_error )} mm · mean error ${mm( result.body.mean_error )} mm` );
		this._render();

	}

	async apply() {

		if ( ! this.result || ! this.view ) return this._say( 'Fit first.' );
		const first = this.samples.find( ( s ) => s.role === ( this.result.kind === 'rotary' ? 'headstock' : 'origin' ) );
		if ( ! first?.joints ) return this._say( `No joint values of ${this.view.name} with the first sample.` );
		const change = {
			op: 'calibrated', robot: this.view.name, measured_by: this.result.measuring, pose: this.result.pose,
			joints: first.joints, axis: this.frameOf.value || null, set: this.setTo.value,
		};
		const result = await this.edits.change( [ change ] );
		if ( result.ok ) this._say( `Applied: ${this.view.name} placed by the fit.` );

	}

	_say( text ) {

		setText( this.resultEl, text );

	}

	_render() {

		this.list.replaceChildren( ...this.samples.map( ( sample, i ) => {

			const item = element( 'li' );
			const [ x, y, z ] = sample.tcp;
			const name = ROLES[ this.kind.value ].find( ( [ value ] ) => value === sample.role )?.[ 1 ] ?? sample.role;
			item.append( element( 'span', null, `${name}: ${fixed( x * 1000 )}, ${fixed( y * 1000 )}, ${fixed( z * 1000 )} mm ` ) );
			const remove = button( '×', `remove sample ${i + 1}`, 'btn btn-small' );
			remove.addEventListener( 'click', () => {

				this.samples.splice( i, 1 );
				this.result = null;
				this._render();

			} );
			item.append( remove );
			return item;

		} ) );
		// Nothing to fit or clear without samples; with some, the server names what is missing.
		this.fitButton.disabled = this.clearButton.disabled = this.samples.length === 0;
		this.applyButton.hidden = this.result === null;
		this._draw();

	}

	// Samples as dots, the fitted frame as axes with its circle (rotary) or line (linear).
	_draw() {

		this._disposeDrawing();
		const material = new THREE.MeshBasicMaterial( { color: COLOR, depthTest: false, transparent: true, opacity: 0.85 } );
		const dot = new THREE.SphereGeometry( SAMPLE_RADIUS, 12, 8 );
		for ( const sample of this.samples ) {

			const mesh = new THREE.Mesh( dot, material );
			mesh.position.fromArray( sample.world );
			mesh.renderOrder = 13;
			this.drawing.add( mesh );

		}
		const measuring = this.result && this.views.get( this.result.measuring );
		if ( ! measuring ) return;
		const fitted = new THREE.Group();
		fitted.name = 'fitted frame';
		fitted.matrixAutoUpdate = false;
		fitted.matrix.multiplyMatrices( matrixOf7( measuring.info.base ), matrixOfPoseVector( this.result.pose ) );
		fitted.matrixWorldNeedsUpdate = true;
		const axes = new THREE.AxesHelper( 0.15 );
		axes.material.depthTest = false;
		axes.renderOrder = 14;
		fitted.add( axes );
		const lineMaterial = new THREE.LineBasicMaterial( { color: COLOR, depthTest: false } );
		let points;
		if ( this.result.radius !== undefined ) {

			points = Array.from( { length: 97 }, ( _, k ) => new THREE.Vector3( Math.cos( k * Math.PI / 48 ), Math.sin( k * Math.PI / 48 ), 0 ).multiplyScalar( this.result.radius ) );

		} else {

			const inverse = fitted.matrix.clone().invert();
			const along = this.samples.map( ( s ) => _v.fromArray( s.world ).applyMatrix4( inverse ).z );
			points = [ new THREE.Vector3( 0, 0, Math.min( 0, ...along ) - 0.05 ), new THREE.Vector3( 0, 0, Math.max( 0, ...along ) + 0.05 ) ];

		}
		const line = new THREE.Line( new THREE.BufferGeometry().setFromPoints( points ), lineMaterial );
		line.renderOrder = 14;
		fitted.add( line );
		this.drawing.add( fitted );
		this.fittedWorld = fitted.matrix.toArray();

	}

	_disposeDrawing() {

		this.fittedWorld = null;
		this.drawing.traverse( ( child ) => {

			child.geometry?.dispose();
			child.material?.dispose();

		} );
		this.drawing.clear();

	}

	/** What the panel holds (tests): samples, the fit, the drawn frame (world, column-major). */
	shown() {

		return {
			robot: this.view?.name ?? null, measuring: this.measuring.value, kind: this.kind.value,
			frameOf: this.frameOf.value, samples: this.samples.map( ( s ) => ( { role: s.role, tcp: s.tcp, world: s.world } ) ),
			result: this.result, text: this.resultEl.textContent, fittedWorld: this.fittedWorld,
			drawn: this.drawing.children.length,
		};

	}

	dispose() {

		this._disposeDrawing();
		this.drawing.removeFromParent();

	}

}

export { Calibration, matrixOf7 };
