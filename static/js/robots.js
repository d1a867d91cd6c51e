import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { RobotView } from './robot.js';

/**
 * Every robot of the cell. Builds the views from `hello`, loads each link mesh
 * once (by URL) and keeps only the newest frame per robot until the next
 * animation frame applies it: a slow page skips stale frames instead of
 * falling behind.
 */
class Robots {

	constructor( world ) {

		this.world = world;
		this.views = new Map(); // robot name -> RobotView, in hello order
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
		this._clear();
		this._cell = cell;
		hello.robots.forEach( ( robot, index ) => {

			const view = new RobotView( robot, index );
			this.views.set( robot.name, view );
			this.world.add( view.group );

		} );

		const generation = ++ this._generation;
		const views = [ ...this.views.values() ];
		Promise.all( views.map( ( view ) => view.load( this._loadMesh ) ) ).then( () => {

			if ( generation === this._generation ) this.meshesLoaded = true;

		}, ( err ) => {

			if ( generation !== this._generation ) return;
			this.loadError = `could not load a link mesh: ${err.message || err}`;
			console.error( 'linkview:', this.loadError );

		} );
		return true;

	}

	/** Keep `frame` as the newest for its robot; older unapplied frames are dropped. */
	queue( frame ) {

		const view = this.views.get( frame.robot );
		if ( view === undefined ) {

			this.unknownFrames ++;
			return;

		}
		view.framesReceived ++;
		this._pending.set( frame.robot, frame );

	}

	/** Apply the newest pending frame of each robot; returns how many robots changed. */
	applyPending() {

		const count = this._pending.size;
		for ( const [ name, frame ] of this._pending ) this.views.get( name ).apply( frame );
		this._pending.clear();
		return count;

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
		// Each use gets its own node tree; geometry and materials are shared.
		return this._meshes.get( url ).then( ( gltf ) => gltf.scene.clone() );

	}

	_clear() {

		for ( const view of this.views.values() ) view.dispose();
		this.views.clear();
		this._pending.clear();
		this.meshesLoaded = false;
		this.loadError = null;

	}

	dispose() {

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
