import * as THREE from 'three';
import { forward, inverse, move, reason } from './api.js';
import { element, setText } from './dom.js';
import { quaternionFromRpy, rpyFromQuaternion } from './rpy.js';
import { RAD_TO_DEG, displayScale, fixed, formatJoint } from './units.js';

const JOG_INTERVAL_MS = 150; // at most one jog move per this, and never two in flight
const HANDS_OFF_MS = 1500; // sliders follow the robot again this long after the last touch
const ARRIVED_M = 0.001; // "there": TCP within 1 mm of the target
const LEFT_M = 0.005; // after arriving, this far off means the robot has moved on
const FREE_RANGE = { rad: Math.PI, m: 1 }; // slider half-range for joints without limits
const TARGET_FIELDS = [ [ 'x', 'mm' ], [ 'y', 'mm' ], [ 'z', 'mm' ], [ 'roll', '°' ], [ 'pitch', '°' ], [ 'yaw', '°' ] ];

/**
 * The simulation panel of a commandable robot (embedded mock, or a server run
 * with --allow-commands): jog sliders, a TCP target typed in or dragged with a
 * gizmo, every configuration reaching it previewed as a translucent ghost, and
 * Move. Everything goes through the server's REST API (/ik, /fk, /move): the
 * page never writes data-layer nodes itself. Coordinates are the robot's base
 * frame; mm and degrees on screen, SI on the wire.
 */
class SimPanel {

	constructor( root, stage ) {

		this.stage = stage;
		this.section = root.getElementById( 'sim' );
		this.offEl = root.getElementById( 'sim-off' ); // what a robot that may not move shows
		this.jogEl = root.getElementById( 'jog' );
		this.solutionsEl = root.getElementById( 'solutions' );
		this.statusEl = root.getElementById( 'sim-status' );
		this.moveButton = root.getElementById( 'move' );
		this.solveButton = root.getElementById( 'solve' );
		this.gizmoBox = root.getElementById( 'gizmo-on' );
		this.gizmoMode = root.getElementById( 'gizmo-mode' );
		this.inputs = {};
		for ( const [ key ] of TARGET_FIELDS ) this.inputs[ key ] = root.getElementById( `target-${key}` );
		this.view = null;
		this.ghosts = [];
		this.solutions = null; // { joints: [[...]], within: [...], tcp: [[...]] }
		this.selected = -1;
		this.moving = null; // a commanded move being followed: { tcp: [x, y, z], closest, arrivedAt, left }
		this.jogs = 0; // move requests sent by jogging (tests: coalesced)
		this._sliders = [];
		this._touched = - Infinity;
		this._jogTarget = null;
		this._jogBusy = false;
		this._jogTimer = null;
		this._jogSentAt = - Infinity;
		this._request = 0; // newer solves win over older answers

		this.marker = this._makeMarker();
		( { controls: this.gizmo, helper: this.gizmoHelper } = stage.gizmo( 0.8, () => this.solve() ) );
		this.gizmo.addEventListener( 'objectChange', () => this._fieldsFromMarker() );

		this.solveButton.addEventListener( 'click', () => this.solve() );
		this.moveButton.addEventListener( 'click', () => this.moveToSelected() );
		root.getElementById( 'target-from-tcp' ).addEventListener( 'click', () => this.targetFromTcp() );
		this.gizmoBox.addEventListener( 'change', () => this._showGizmo() );
		this.gizmoMode.addEventListener( 'change', () => this.gizmo.setMode( this.gizmoMode.value ) );
		for ( const input of Object.values( this.inputs ) ) {

			input.addEventListener( 'change', () => this._markerFromFields() );
			input.addEventListener( 'keydown', ( event ) => {

				if ( event.key === 'Enter' ) this.solve();

			} );

		}

	}

	_makeMarker() {

		const marker = new THREE.Group();
		marker.name = 'target';
		const ball = new THREE.Mesh(
			new THREE.SphereGeometry( 0.018, 16, 8 ), // flat colour: as robot.js's TCP ball
			new THREE.MeshBasicMaterial( { color: 0xff2d95, transparent: true, opacity: 0.7, depthTest: false } )
		);
		ball.renderOrder = 12;
		const axes = new THREE.AxesHelper( 0.08 );
		axes.material.depthTest = false;
		axes.renderOrder = 12;
		marker.add( ball, axes );
		marker.visible = false;
		return marker;

	}

	/** Show the panel for `view` (a RobotView) if it is commandable, else hide it. */
	setRobot( view ) {

		this._clearGhosts();
		this.moving = null;
		this.marker.removeFromParent();
		this.marker.visible = false;
		this.gizmo.detach();
		this.view = view && view.info.commandable ? view : null;
		this.section.hidden = this.view === null;
		this.offEl.hidden = ! view || view.info.commandable;
		setText( this.statusEl, '' );
		this.moveButton.disabled = true;
		this._buildJog();
		if ( this.view === null ) return;
		this.view.group.add( this.marker ); // the target lives in the robot's base frame
		this.targetFromTcp();

	}

	_buildJog() {

		this.jogEl.replaceChildren();
		this._sliders = [];
		if ( ! this.view ) return;
		for ( const joint of this.view.info.joints ) {

			const scale = displayScale( joint );
			const [ lo, hi ] = joint.limits ?? [ - FREE_RANGE[ joint.unit ], FREE_RANGE[ joint.unit ] ];
			const row = element( 'label', 'jog-row' );
			const slider = element( 'input' );
			slider.type = 'range';
			slider.min = String( lo * scale );
			slider.max = String( hi * scale );
			slider.step = joint.unit === 'm' ? '1' : '0.5';
			slider.setAttribute( 'aria-label', `jog ${joint.name}` );
			const output = element( 'output', 'value', '—' );
			row.append( element( 'span', 'name', joint.name ), slider, output );
			slider.addEventListener( 'input', () => {

				this._touched = performance.now();
				setText( output, formatJoint( Number( slider.value ) / scale, joint ) );
				this._jog();

			} );
			slider.addEventListener( 'pointerdown', () => {

				this._touched = performance.now();

			} );
			this.jogEl.append( row );
			this._sliders.push( { slider, output, joint, scale } );

		}

	}

	// Coalesce: the newest slider values go out at most every JOG_INTERVAL_MS, one request at a time.
	_jog() {

		this._jogTarget = this._sliders.map( ( { slider, scale } ) => Number( slider.value ) / scale );
		this._pumpJog();

	}

	_pumpJog() {

		if ( this._jogBusy || this._jogTarget === null || ! this.view ) return;
		const wait = this._jogSentAt + JOG_INTERVAL_MS - performance.now();
		if ( wait > 0 ) {

			if ( this._jogTimer === null ) this._jogTimer = setTimeout( () => {

				this._jogTimer = null;
				this._pumpJog();

			}, wait );
			return;

		}
		const target = this._jogTarget;
		this._jogTarget = null;
		this._jogBusy = true;
		this._jogSentAt = performance.now();
		this.jogs ++;
		this.moving = null; // jogging takes over from a followed move
		move( this.view.name, target ).then( ( result ) => {

			if ( ! result.ok ) setText( this.statusEl, `Jog refused: ${reason( result )}` );

		}, ( err ) => setText( this.statusEl, `Jog failed: ${err.message}` ) ).finally( () => {

			this._jogBusy = false;
			this._pumpJog();

		} );

	}

	/** Fill the target fields (and the marker) with the robot's current TCP. */
	targetFromTcp() {

		const frame = this.view && this.view.goodFrame;
		const tcp = frame && frame.tcp.length === 7 ? frame.tcp : [ this.view.tcp.position.x, this.view.tcp.position.y, this.view.tcp.position.z,
			this.view.tcp.quaternion.x, this.view.tcp.quaternion.y, this.view.tcp.quaternion.z, this.view.tcp.quaternion.w ];
		this._setFields( tcp );
		this._markerFromFields();

	}

	_setFields( tcp ) {

		const rpy = rpyFromQuaternion( tcp[ 3 ], tcp[ 4 ], tcp[ 5 ], tcp[ 6 ] );
		const values = [ tcp[ 0 ] * 1000, tcp[ 1 ] * 1000, tcp[ 2 ] * 1000, ...rpy.map( ( a ) => a * RAD_TO_DEG ) ];
		TARGET_FIELDS.forEach( ( [ key ], i ) => {

			this.inputs[ key ].value = values[ i ].toFixed( 1 );

		} );

	}

	/** The typed target as [x, y, z, qx, qy, qz, qw] (m, base frame), or null if a field is not a number. */
	target() {

		const v = TARGET_FIELDS.map( ( [ key ] ) => Number.parseFloat( this.inputs[ key ].value ) );
		if ( v.some( ( x ) => ! Number.isFinite( x ) ) ) return null;
		const q = quaternionFromRpy( v[ 3 ] / RAD_TO_DEG, v[ 4 ] / RAD_TO_DEG, v[ 5 ] / RAD_TO_DEG );
		return [ v[ 0 ] / 1000, v[ 1 ] / 1000, v[ 2 ] / 1000, ...q ];

	}

	_markerFromFields() {

		const tcp = this.target();
		if ( ! tcp || ! this.view ) return;
		this.marker.position.set( tcp[ 0 ], tcp[ 1 ], tcp[ 2 ] );
		this.marker.quaternion.set( tcp[ 3 ], tcp[ 4 ], tcp[ 5 ], tcp[ 6 ] );
		this.marker.visible = true;

	}

	_fieldsFromMarker() {

		const p = this.marker.position;
		const q = this.marker.quaternion;
		this._setFields( [ p.x, p.y, p.z, q.x, q.y, q.z, q.w ] );

	}

	_showGizmo() {

		const on = this.gizmoBox.checked && this.view !== null;
		if ( on ) this.gizmo.attach( this.marker );
		else this.gizmo.detach();
		this.gizmoHelper.visible = on;

	}

	/** Solve the target with /ik (all configurations), then draw each as a ghost (/fk with links). */
	async solve() {

		const view = this.view;
		const tcp = this.target();
		if ( ! view ) return;
		if ( ! tcp ) {

			setText( this.statusEl, 'The target needs a number in every field.' );
			return;

		}
		this._markerFromFields();
		this.moving = null; // a new target: the last move's status gives way
		const request = ++ this._request;
		this._clearGhosts();
		this.moveButton.disabled = true;
		setText( this.statusEl, 'Solving…' );
		const current = view.goodFrame ? Array.from( view.goodFrame.joints ) : view.info.joints.map( () => 0 );
		const ik = await inverse( view.name, tcp, current );
		if ( request !== this._request ) return;
		if ( ! ik.ok ) {

			setText( this.statusEl, `Could not solve: ${reason( ik )}` );
			return;

		}
		const answer = ik.body;
		if ( answer.solutions.length === 0 ) {

			setText( this.statusEl, `Unreachable: ${answer.error || 'no configuration reaches this target'}.` );
			return;

		}
		const fk = await forward( view.name, answer.solutions, true );
		if ( request !== this._request ) return;
		if ( ! fk.ok ) {

			setText( this.statusEl, `Could not preview: ${reason( fk )}` );
			return;

		}
		this.solutions = { joints: answer.solutions, within: answer.within_limits, tcp: fk.body.tcp };
		this.ghosts = answer.solutions.map( ( _, i ) => {

			const ghost = view.makeGhost();
			ghost.setPoses( fk.body.links[ i ] );
			this.stage.world.add( ghost.group );
			return ghost;

		} );
		this._listSolutions( current, answer );
		const nearest = answer.best ? this._nearest( answer.solutions, answer.best ) : -1;
		this.select( nearest );
		const outside = answer.within_limits.filter( ( w ) => ! w ).length;
		setText( this.statusEl, answer.ok
			? `${answer.solutions.length} configuration${answer.solutions.length > 1 ? 's' : ''} reach the target${outside ? `, ${outside} outside the joint limits` : ''}.`
			: `Unreachable within the limits: ${answer.error}.` );

	}

	_nearest( rows, joints ) {

		let best = - 1;
		let bestDistance = Infinity;
		rows.forEach( ( row, i ) => {

			const d = row.reduce( ( sum, value, j ) => sum + ( value - joints[ j ] ) ** 2, 0 );
			if ( d < bestDistance ) {

				bestDistance = d;
				best = i;

			}

		} );
		return best;

	}

	_listSolutions( current, answer ) {

		this.solutionsEl.replaceChildren();
		const joints = this.view.info.joints;
		answer.solutions.forEach( ( row, i ) => {

			const item = element( 'li' );
			const label = element( 'label', 'solution' );
			const radio = element( 'input' );
			radio.type = 'radio';
			radio.name = 'solution';
			radio.value = String( i );
			radio.disabled = ! answer.within_limits[ i ];
			radio.addEventListener( 'change', () => this.select( i ) );
			// Which configuration, how far from now and whether allowed; the raw joints in the tooltip.
			const name = answer.configurations ? answer.configurations[ i ] : `configuration ${i + 1}`;
			const within = answer.within_limits[ i ];
			label.append(
				radio,
				element( 'span', 'configuration', name ),
				element( 'span', 'distance', largestMove( row, current, joints ) ),
				element( 'span', within ? 'inside' : 'outside', within ? 'within limits' : 'outside the limits' ),
			);
			const text = row.map( ( value, j ) => `${joints[ j ].name} ${formatJoint( value, joints[ j ] )}` ).join( ', ' );
			label.title = `#${i + 1} ${name}: ${text}`;
			item.append( label );
			this.solutionsEl.append( item );

		} );

	}

	/** Preselect / select configuration `index` (-1: none). */
	select( index ) {

		this.selected = index;
		this.ghosts.forEach( ( ghost, i ) => ghost.setLook( i === index, ! this.solutions.within[ i ] ) );
		this.solutionsEl.querySelectorAll( 'input[type=radio]' ).forEach( ( radio, i ) => {

			radio.checked = i === index;

		} );
		this.moveButton.disabled = index < 0 || ! this.solutions.within[ index ];

	}

	/** Command the selected configuration, then watch the robot get there. */
	async moveToSelected() {

		const view = this.view;
		if ( ! view || this.selected < 0 ) return;
		const joints = this.solutions.joints[ this.selected ];
		const tcp = this.solutions.tcp[ this.selected ];
		const result = await move( view.name, joints );
		if ( ! result.ok ) {

			setText( this.statusEl, `Move refused: ${reason( result )}` );
			return;

		}
		this.moving = { tcp: tcp.slice( 0, 3 ), closest: Infinity, arrivedAt: null, left: false };
		setText( this.statusEl, 'Moving…' );

	}

	/** Follow the robot (a few times a second): sliders, and how far a commanded move still has to go. */
	update( now = performance.now() ) {

		const view = this.view;
		if ( ! view || ! view.goodFrame ) return;
		const frame = view.goodFrame;
		if ( now - this._touched > HANDS_OFF_MS && ! this._jogBusy ) {

			this._sliders.forEach( ( { slider, output, joint, scale }, i ) => {

				const value = frame.joints[ i ];
				if ( ! Number.isFinite( value ) ) return;
				slider.value = String( value * scale );
				setText( output, formatJoint( value, joint ) );

			} );

		}
		const moving = this.moving;
		if ( moving && frame.tcp.length === 7 ) {

			const d = Math.hypot( frame.tcp[ 0 ] - moving.tcp[ 0 ], frame.tcp[ 1 ] - moving.tcp[ 1 ], frame.tcp[ 2 ] - moving.tcp[ 2 ] );
			moving.closest = Math.min( moving.closest, d );
			setText( this.statusEl, moveStatus( moving, d, view.info, now ) );

		}

	}

	_clearGhosts() {

		for ( const ghost of this.ghosts ) ghost.dispose();
		this.ghosts = [];
		this.solutions = null;
		this.selected = - 1;
		this.solutionsEl.replaceChildren();

	}

	dispose() {

		this._clearGhosts();
		clearTimeout( this._jogTimer );
		this.gizmo.detach();
		this.gizmo.dispose();
		this.gizmoHelper.removeFromParent();
		this.marker.removeFromParent();

	}

}

/**
 * How far joints `row` are from `current` (SI, hello order), as a person reads it: the largest
 * single joint move, in degrees for rotary joints and millimetres for linear ones.
 */
function largestMove( row, current, joints ) {

	const largest = { rad: 0, m: 0 };
	row.forEach( ( value, j ) => {

		const unit = joints[ j ].unit === 'm' ? 'm' : 'rad';
		largest[ unit ] = Math.max( largest[ unit ], Math.abs( value - current[ j ] ) );

	} );
	const parts = [];
	if ( joints.some( ( joint ) => joint.unit !== 'm' ) ) parts.push( `${fixed( largest.rad * RAD_TO_DEG )}°` );
	if ( joints.some( ( joint ) => joint.unit === 'm' ) ) parts.push( `${fixed( largest.m * 1000 )} mm` );
	return `largest joint move ${parts.join( ', ' )}`;

}

/**
 * What a followed move's status says at TCP distance `d` (m) from its target: it follows
 * the actual pose, never a stale "Arrived". `robot.hold_s` is how long an embedded mock
 * holds the commanded pose before its demo cycle resumes (null: a real controller).
 */
function moveStatus( moving, d, robot, now ) {

	if ( moving.left ) {

		const mm = ( d * 1000 ).toFixed( 0 );
		if ( robot.hold_s == null ) return `Moved on: the TCP is ${mm} mm from the target (the controller moved it).`;
		return `Demo cycle resumed: the TCP is ${mm} mm from the target.`;

	}
	if ( moving.arrivedAt === null ) {

		if ( d > ARRIVED_M ) return `Moving: ${( d * 1000 ).toFixed( 1 )} mm to go.`;
		moving.arrivedAt = now;

	}
	if ( d > LEFT_M ) {

		moving.left = true;
		return moveStatus( moving, d, robot, now );

	}
	const arrived = `Arrived: the TCP is ${( d * 1000 ).toFixed( 2 )} mm from the target.`;
	if ( robot.hold_s == null ) return arrived;
	const left = Math.max( 0, Math.ceil( robot.hold_s - ( now - moving.arrivedAt ) / 1000 ) );
	return `${arrived} Holding the commanded pose (demo cycle resumes in ${left} s).`;

}

export { SimPanel };
