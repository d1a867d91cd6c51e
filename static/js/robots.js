import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { forward } from './api.js';
import { JointHistory } from './plots.js';
import { RobotView } from './robot.js';

/**
 * Every robot of the cell. Builds the views from `hello`, loads each link mesh
 * once (by URL), draws each robot at its zero pose until its first frame, and
 * keeps only the newest frame per robot until the next animation frame applies
 * it: a slow page skips stale frames instead of falling behind. Joint values of
 * every frame go to the robot's JointHistory (the plots) on arrival.
 */
class Robots {

	constructor( world ) {

		this.world = world;
		this.views = new Map(); // robot name -> RobotView, in hello order
		this.byIndex = []; // hello index -> RobotView (protocol 2 names robots by index)
		this.histories = new Map(); // robot name -> JointHistory
		this.meshesLoaded = false;
		this.loadError = null;
		this.unknownFrames = 0;
		this._pending = new Map(); // robot name -> newest frame not yet applied
		this._loader = new GLTFLoader();
		this._meshes = new Map(); // mesh URL -> Promise<gltf>
		this._cell = null;
		this._generation = 0;
		this._loadMesh = ( url ) => this._mesh( url );

	}

	/**
	 * Build the robots announced by `hello`. A reconnect to the same cell keeps
	 * the existing views (and their poses); returns whether anything was rebuilt.
	 */
	setHello( hello ) {

		const cell = JSON.stringify( hello.robots );
		if ( cell === this._cell ) return false;
		const previous = this.views;
		this._clear();
		this._cell = cell;
		hello.robots.forEach( ( robot, index ) => {

			const view = new RobotView( robot, index );
			const before = previous.get( robot.name );
			if ( before ) {

				view.setShown( before.shown );
				view.setTrail( before.trailOn );

			}
			this.views.set( robot.name, view );
			this.byIndex.push( view );
			this.histories.set( robot.name, new JointHistory( robot.joints ) );
			this.world.add( view.group );

		} );
		for ( const old of previous.values() ) old.dispose();

		const generation = ++ this._generation;
		const views = [ ...this.views.values() ];
		Promise.all( views.map( ( view ) => view.load( this._loadMesh ) ) ).then( () => {

			if ( generation === this._generation ) this.meshesLoaded = true;

		}, ( err ) => {

			if ( generation !== this._generation ) return;
			this.loadError = `could not load a link mesh: ${err.message || err}`;
			console.error( 'linkview:', this.loadError );

		} );
		for ( const view of views ) this._poseAtZero( view, generation );
		return true;

	}

	// Until its first frame a robot is drawn at joints 0 (clamped into its limits), greyed.
	async _poseAtZero( view, generation ) {

		const zero = view.info.joints.map( ( joint ) => joint.limits ? Math.min( Math.max( 0, joint.limits[ 0 ] ), joint.limits[ 1 ] ) : 0 );
		if ( zero.length === 0 ) return;
		let result;
		try {

			result = await forward( view.name, [ zero ], true );

		} catch {

			return; // the server went away; the frames will pose the robot
		}
		if ( generation !== this._generation || ! result.ok || ! result.body.ok[ 0 ] ) return;
		view.setZeroPose( result.body.links[ 0 ], result.body.tcp[ 0 ] );

	}

	/** Keep `frame` as the newest for its robot; older unapplied frames are dropped. */
	queue( frame, arrivalMs ) {

		const view = this.views.get( frame.robot );
		if ( view === undefined ) {

			this.unknownFrames ++;
			return;

		}
		view.framesReceived ++;
		// Plotted against the sample's own time: frames a busy page got in one burst
		// still sit where they were sampled.
		if ( frame.joints.length ) this.histories.get( frame.robot ).add( frame.joints, frame.t_source * 1000, arrivalMs );
		this._pending.set( frame.robot, frame );

	}

	/** Apply the newest pending frame of each robot; returns the frames applied. */
	applyPending( timeMs ) {

		const applied = [ ...this._pending.values() ];
		for ( const frame of applied ) this.views.get( frame.robot ).apply( frame, timeMs );
		this._pending.clear();
		return applied;

	}

	/** Whether every robot has been drawn at a real pose at least once. */
	allPosed() {

		for ( const view of this.views.values() ) if ( view.goodFrame === null ) return false;
		return this.views.size > 0;

	}

	framesApplied() {

		const counts = {};
		for ( const [ name, view ] of this.views ) counts[ name ] = view.framesApplied;
		return counts;

	}

	linkMatrices( name ) {

		const view = this.views.get( name );
		return view ? view.linkMatrices() : null;

	}

	_mesh( url ) {

		if ( ! this._meshes.has( url ) ) this._meshes.set( url, this._loader.loadAsync( url ) );
		// Each use gets its own node tree; geometry and materials are shared. The URL
		// marks the tree's root: the 2D view draws its coarse copy (view2d/coarse.js).
		return this._meshes.get( url ).then( ( gltf ) => {

			const root = gltf.scene.clone();
			root.userData.meshUrl = url;
			return root;

		} );

	}

	_clear() {

		this.views = new Map();
		this.byIndex = [];
		this.histories = new Map();
		this._pending.clear();
		this.meshesLoaded = false;
		this.loadError = null;

	}

	dispose() {

		for ( const view of this.views.values() ) view.dispose();
		this._clear();
		this._generation ++;
		for ( const promise of this._meshes.values() ) {

			promise.then( ( gltf ) => gltf.scene.traverse( ( child ) => {

				if ( ! child.isMesh ) return;
				child.geometry.dispose();
				child.material.dispose();

			} ), () => {} );

		}
		this._meshes.clear();

	}

}

export { Robots };
