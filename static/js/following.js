import { nowMs } from './clock.js';
import { checkbox, element, setText } from './dom.js';
import { displayScale, displayUnit, fixed } from './units.js';

const WINDOW_MS = 10000; // the largest following error shown is over this long
const KEPT = 600; // samples remembered per robot (12 s at 50 per second)

/**
 * Setpoint and actual, for robots whose joints name a setpoint node: a
 * "setpoint" switch in the robot's card (off by default) that draws the
 * setpoint pose the server sends as a translucent ghost beside the actual
 * robot, and shows the largest following error of the last 10 s: at the TCP
 * in mm, and per joint in degrees (mm for linear joints). The page computes
 * no kinematics: both poses come in every frame.
 */
class Following {

	constructor( root, world ) {

		this.root = root;
		this.world = world;
		this._robots = new Map(); // robot name -> state

	}

	/** A switch per robot of `hello` that has setpoints; `views`: name -> RobotView. */
	setHello( hello, views ) {

		const before = this._robots;
		this.dispose();
		for ( const robot of hello.robots ) {

			if ( robot.joints.length === 0 || ! robot.joints.every( ( joint ) => joint.setpoint ) ) continue;
			const card = this.root.querySelector( `#robots [data-robot="${CSS.escape( robot.name )}"]` );
			const view = views.get( robot.name );
			if ( ! card || ! view ) continue;
			const box = checkbox( 'setpoint', false, `draw the setpoint of ${robot.name} as a ghost` );
			const readout = element( 'div', 'following muted' );
			readout.setAttribute( 'aria-label', `largest following error of ${robot.name}` );
			readout.hidden = true;
			const section = element( 'div', 'following-controls' );
			section.append( box.label, readout );
			card.append( section );
			const state = { robot, view, box: box.input, readout, ghost: null, ghostJoints: null, history: [] };
			this._robots.set( robot.name, state );
			box.input.addEventListener( 'change', () => this.setOn( robot.name, box.input.checked ) );
			if ( before.get( robot.name )?.wasOn ) {

				box.input.checked = true;
				this.setOn( robot.name, true );

			}

		}

	}

	/** Draw (or stop drawing) `name`'s setpoint ghost and its following error. */
	setOn( name, on ) {

		const state = this._robots.get( name );
		if ( ! state || on === ( state.ghost !== null ) ) return;
		state.box.checked = on;
		state.readout.hidden = ! on;
		state.history = [];
		state.ghostJoints = null;
		if ( on ) {

			state.ghost = state.view.makeGhost();
			state.ghost.setLook( true, false ); // the stronger of the two ghost looks: it moves
			state.ghost.group.visible = false; // until the first setpoint
			this.world.add( state.ghost.group );

		} else {

			state.ghost.dispose();
			state.ghost = null;

		}

	}

	/** `frame` was just applied to its robot: move the ghost to its setpoint pose. */
	applied( frame ) {

		const state = this._robots.get( frame.robot );
		if ( ! state || state.ghost === null || ! frame.ok || ! frame.setpoint ) return;
		state.ghost.setPoses( frame.setpoint.links, frame.setpoint.tcp );
		state.ghost.group.visible = state.view.group.visible;
		state.ghostJoints = frame.setpoint.joints;

	}

	/** `frame` arrived (every one, before the render loop coalesces them): note the error. */
	received( frame, timeMs ) {

		const state = this._robots.get( frame.robot );
		if ( ! state || state.ghost === null || ! frame.ok || ! frame.setpoint ) return;
		const setpoint = frame.setpoint;
		const joints = Array.from( frame.joints, ( q, i ) => setpoint.joints[ i ] - q );
		const tcp = Math.hypot( setpoint.tcp[ 0 ] - frame.tcp[ 0 ], setpoint.tcp[ 1 ] - frame.tcp[ 1 ], setpoint.tcp[ 2 ] - frame.tcp[ 2 ] );
		state.history.push( { time: timeMs, t_source: frame.t_source, tcp, joints, actual: Array.from( frame.joints ), setpoint: Array.from( setpoint.joints ) } );
		if ( state.history.length > KEPT ) state.history.splice( 0, state.history.length - KEPT );

	}

	/** The largest errors of `name` over the last 10 s: { tcp (m), joints (SI) }, or null. */
	largest( name, nowMs ) {

		const state = this._robots.get( name );
		if ( ! state || state.history.length === 0 ) return null;
		const recent = state.history.filter( ( entry ) => nowMs - entry.time <= WINDOW_MS );
		if ( recent.length === 0 ) return null;
		const joints = state.robot.joints.map( ( _, i ) => Math.max( ...recent.map( ( entry ) => Math.abs( entry.joints[ i ] ) ) ) );
		return { tcp: Math.max( ...recent.map( ( entry ) => entry.tcp ) ), joints };

	}

	/** Refresh the readouts (a few times a second). */
	update( nowMs ) {

		for ( const [ name, state ] of this._robots ) {

			if ( state.ghost === null ) continue;
			const largest = this.largest( name, nowMs );
			if ( largest === null ) {

				setText( state.readout, 'following error: waiting for a setpoint' );
				continue;

			}
			const joints = state.robot.joints.map( ( joint, i ) => `${joint.name} ${fixed( largest.joints[ i ] * displayScale( joint ), 2 )}${displayUnit( joint )}` );
			setText( state.readout, `largest following error, 10 s: TCP ${fixed( largest.tcp * 1000, 2 )} mm · ${joints.join( ' · ' )}` );

		}

	}

	/**
	 * For tests and the console: { on, ghostVisible, readout, largest, recent (every frame
	 * received: t_source, actual and setpoint joints), ghostJoints and ghostMatrices (the
	 * setpoint drawn now) } of `name`, or null.
	 */
	shown( name ) {

		const state = this._robots.get( name );
		if ( ! state ) return null;
		return {
			on: state.ghost !== null,
			ghostVisible: state.ghost !== null && state.ghost.group.visible,
			readout: state.readout.hidden ? null : state.readout.textContent,
			largest: this.largest( name, nowMs() ),
			recent: state.history.map( ( entry ) => ( { t_source: entry.t_source, actual: entry.actual, setpoint: entry.setpoint } ) ),
			ghostJoints: state.ghost === null || state.ghostJoints === null ? null : Array.from( state.ghostJoints ),
			ghostMatrices: state.ghost === null ? null : state.ghost.linkMatrices(),
		};

	}

	dispose() {

		for ( const state of this._robots.values() ) {

			state.wasOn = state.ghost !== null;
			if ( state.ghost ) state.ghost.dispose();
			state.ghost = null;

		}
		const kept = this._robots;
		this._robots = new Map();
		return kept;

	}

}

export { Following };
