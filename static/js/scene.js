import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { TransformControls } from 'three/addons/controls/TransformControls.js';
import { RoomEnvironment } from 'three/addons/environments/RoomEnvironment.js';
import { FrameGate } from './frame_gate.js';
import { OrientationAids } from './orientation.js';
import { CanvasRenderer } from './view2d/canvas_renderer.js';

// The robot data is Z up (metres); make every camera and light agree.
THREE.Object3D.DEFAULT_UP.set( 0, 0, 1 );

const _box = new THREE.Box3();
const _size = new THREE.Vector3();
const _centre = new THREE.Vector3();
const _offset = new THREE.Vector3();
const _sphere = new THREE.Sphere();

/** Where the camera looks from, per view preset (Z up; "front" looks along +Y). */
const VIEWS = {
	iso: new THREE.Vector3( 0.55, - 0.75, 0.45 ).normalize(),
	top: new THREE.Vector3( 0, - 1e-3, 1 ).normalize(), // a hair off the pole: OrbitControls needs a heading
	front: new THREE.Vector3( 0, - 1, 0.02 ).normalize(),
	side: new THREE.Vector3( 1, 0, 0.02 ).normalize(),
};

const MIN_FREE_SHARE = 0.3; // of the window's width: narrower, and the canvas spans the window
const GRID_SIZE_M = 8;
const GRID_DIVISIONS = 32; // 250 mm cells, written on the floor by OrientationAids

const THEMES = {
	light: { grid: [ 0x9aa1ab, 0xc6cbd2 ], shadow: 0x1d2430 },
	dark: { grid: [ 0x5d6573, 0x3a414c ], shadow: 0x000000 },
};

/**
 * Renderer, orbit camera, lights, floor grid and shadows: everything in the view
 * that is not a robot. Robots are added under `world`. Quality settings
 * (shadows, antialiasing, pixel ratio, environment light) can change at run
 * time; antialiasing is fixed per WebGL context, so changing it makes a new
 * renderer (the controls listen on the container, not the canvas, and survive).
 */
class Stage {

	/**
	 * `settings`: the quality to start with (quality.js `settings()`); `webgl`: false
	 * where the browser has none; `view`: '3d' (WebGL) or '2d' (Canvas 2D, view2d/),
	 * always '2d' without WebGL.
	 */
	constructor( container, settings, { webgl = true, view = '3d' } = {} ) {

		this.container = container;
		this.settings = { ...settings };
		this._loop = null;
		this.insets = { left: 0, right: 0, bottom: 0 }; // px of the window covered by panels and the timeline bar
		this.viewRect = { left: 0, width: 1, height: 1, bottom: 0 }; // where the canvas lies: set by resize()
		this._gizmos = []; // TransformControls made by gizmo(), whose pointer resize() maps

		this.scene = new THREE.Scene();
		this.camera = new THREE.PerspectiveCamera( 40, 1, 0.01, 100 );
		this.camera.position.set( 1.6, - 2.2, 1.4 );

		this.webgl = webgl;
		this.view = webgl ? view : '2d';
		this.gate = new FrameGate(); // frames that would show nothing new are not drawn
		this.framesDrawn = 0;
		this.renderer = this._makeRenderer();
		this.environment = null; // made when first wanted: seconds of work on software WebGL

		this.controls = new OrbitControls( this.camera, container );
		this.controls.target.set( 0, 0, 0.3 );
		this.controls.enableDamping = true;
		this.controls.dampingFactor = 0.1;
		this.controls.maxPolarAngle = Math.PI * 0.495;
		this.controls.update();

		this._addLights();
		this._addFloor();

		this.world = new THREE.Group();
		this.world.name = 'world';
		this.scene.add( this.world );

		this._dark = window.matchMedia( '(prefers-color-scheme: dark)' );
		this._onTheme = () => this._applyTheme();
		this._dark.addEventListener( 'change', this._onTheme );
		this._applyTheme();

		this._onResize = () => this.resize();
		window.addEventListener( 'resize', this._onResize );
		this.resize();
		this._applySettings();

	}

	_makeRenderer() {

		if ( this.view === '2d' ) {

			const canvas = new CanvasRenderer();
			this.container.appendChild( canvas.domElement );
			return canvas;

		}
		const renderer = new THREE.WebGLRenderer( { antialias: this.settings.antialias, alpha: true } );
		renderer.setPixelRatio( this.settings.pixelRatio );
		renderer.toneMapping = THREE.NeutralToneMapping;
		renderer.shadowMap.enabled = this.settings.shadows;
		renderer.shadowMap.type = THREE.PCFShadowMap;
		renderer.domElement.setAttribute( 'aria-label', '3D view of the cell: drag to orbit, wheel to zoom, Home to reset' );
		renderer.domElement.setAttribute( 'role', 'img' );
		this.container.appendChild( renderer.domElement );
		return renderer;

	}

	// Soft image-based light from a neutral room; the room is Y up, so turn it to Z up.
	_makeEnvironment() {

		if ( this.view === '2d' ) return; // the room's light is baked by the GPU
		this.pmrem = new THREE.PMREMGenerator( this.renderer );
		const room = new RoomEnvironment();
		this.environment = this.pmrem.fromScene( room, 0.04 ).texture;
		room.dispose();
		this.scene.environmentIntensity = 0.4;
		this.scene.environmentRotation.set( Math.PI / 2, 0, 0 );

	}

	_disposeEnvironment() {

		this.scene.environment = null;
		if ( ! this.environment ) return;
		this.environment.dispose();
		this.pmrem.dispose();
		this.environment = null;

	}

	_addLights() {

		this.hemi = new THREE.HemisphereLight( 0xf4f6ff, 0x8a8f99, 0.6 );
		this.scene.add( this.hemi );

		const sun = new THREE.DirectionalLight( 0xffffff, 1.9 );
		sun.position.set( 2.5, - 1.5, 4.0 );
		sun.castShadow = this.settings.shadows;
		sun.shadow.mapSize.set( 2048, 2048 );
		sun.shadow.bias = - 0.0004;
		sun.shadow.normalBias = 0.01;
		sun.shadow.radius = 3;
		this.scene.add( sun );
		this.scene.add( sun.target );
		this.sun = sun;

		const fill = new THREE.DirectionalLight( 0xdde6ff, 0.5 );
		fill.position.set( - 3, 2, 1.5 );
		this.scene.add( fill );

	}

	_addFloor() {

		const floor = new THREE.Mesh(
			new THREE.PlaneGeometry( 40, 40 ),
			new THREE.ShadowMaterial( { color: 0x1d2430, opacity: 0.18, depthWrite: false } )
		);
		floor.receiveShadow = true;
		floor.renderOrder = - 2;
		this.scene.add( floor );
		this.floor = floor;
		this.orientation = new OrientationAids( this.scene ); // world axes, grid spacing
		this._makeGrid( THEMES.light );

	}

	_makeGrid( theme ) {

		if ( this.grid ) {

			this.grid.removeFromParent();
			this.grid.dispose();

		}
		// GridHelper lies in XZ; the floor here is the XY plane.
		const grid = new THREE.GridHelper( GRID_SIZE_M, GRID_DIVISIONS, theme.grid[ 0 ], theme.grid[ 1 ] );
		grid.rotation.x = Math.PI / 2;
		grid.material.transparent = true;
		grid.material.opacity = 0.7;
		grid.material.depthWrite = false;
		grid.renderOrder = - 1; // lines over the floor shadow (renderOrder - 2)
		this.scene.add( grid );
		this.grid = grid;
		this.orientation.setGridSpacing( GRID_SIZE_M / GRID_DIVISIONS );

	}

	_applyTheme() {

		const theme = this._dark.matches ? THEMES.dark : THEMES.light;
		this._makeGrid( theme );
		this.gate.invalidate();
		this.floor.material.color.set( theme.shadow );
		this.floor.material.opacity = this._dark.matches ? 0.35 : 0.18;

	}

	/** Run `loop(time)` on every animation frame (kept across renderer changes). */
	setAnimationLoop( loop ) {

		this._loop = loop;
		this.renderer.setAnimationLoop( loop );

	}

	/**
	 * Change quality: any of shadows, antialias, environment (bool), pixelRatio (number);
	 * simpleMaterials is kept here for the robots to read.
	 */
	setQuality( settings ) {

		const next = { ...this.settings, ...settings };
		const changed = ( key ) => next[ key ] !== this.settings[ key ];
		const rebuild = changed( 'antialias' );
		const recompile = changed( 'shadows' ) || changed( 'environment' );
		const resize = changed( 'pixelRatio' );
		this.settings = next;
		this.gate.invalidate();
		if ( rebuild ) this._replaceRenderer();
		if ( resize ) {

			this.renderer.setPixelRatio( next.pixelRatio );
			this.resize();

		}
		this._applySettings();
		if ( recompile ) this.scene.traverse( ( object ) => {

			if ( object.material ) for ( const m of [].concat( object.material ) ) m.needsUpdate = true;

		} );

	}

	/** Draw with WebGL ('3d') or Canvas 2D ('2d'); '3d' needs WebGL. Returns the view now drawn. */
	setView( view ) {

		if ( view === this.view || ( view === '3d' && ! this.webgl ) ) return this.view;
		this.view = view;
		this._replaceRenderer();
		this._applySettings();
		return this.view;

	}

	/** Whether robots draw their merged, simplified meshes (the lowest level, in WebGL only). */
	get simpleMaterials() {

		return this.settings.simpleMaterials && this.view === '3d';

	}

	_replaceRenderer() {

		const old = this.renderer;
		old.setAnimationLoop( null );
		this._disposeEnvironment(); // made by the old renderer
		this.renderer = this._makeRenderer();
		old.domElement.remove();
		old.dispose();
		this.renderer.setAnimationLoop( this._loop );
		this.resize();
		this.gate.invalidate();

	}

	// What the settings say beyond the renderer itself: shadows, floor, environment light.
	_applySettings() {

		const { shadows, environment } = this.settings;
		this.renderer.shadowMap.enabled = shadows;
		this.sun.castShadow = shadows;
		this.floor.visible = shadows;
		if ( environment && this.environment === null ) this._makeEnvironment();
		this.scene.environment = environment ? this.environment : null; // null without WebGL
		// Without the room's light the scene would be dark: the sky light makes up for it.
		this.hemi.intensity = environment ? 0.6 : 1.5;

	}

	/**
	 * Pixels of the window's left, right and bottom covered by panels and the timeline
	 * bar. The canvas spans only the part they leave free: without a GPU every pixel of
	 * the canvas is drawn and composited in software each frame, and those under an
	 * opaque panel are never seen (bench/page_fps.py). Where that part would be too
	 * narrow, the canvas spans the window.
	 */
	setInsets( left, right, bottom = 0 ) {

		const now = this.insets;
		// Unchanged (panels re-report on every window resize): the window's own resize
		// listener measures the view once.
		if ( now.left === left && now.right === right && now.bottom === bottom ) return;
		this.insets = { left, right, bottom };
		this.resize();

	}

	/**
	 * Where the canvas lies in the container (CSS px): { left, width, height } from its top.
	 * Measured when the window or the insets change (resize()), not on each call: reading
	 * the container's size forces a style and layout pass, and the labels ask every frame.
	 */
	_measureView() {

		const full = this.container.clientWidth || window.innerWidth;
		const tall = this.container.clientHeight || window.innerHeight;
		const free = full - this.insets.left - this.insets.right;
		if ( free < MIN_FREE_SHARE * full ) return { left: 0, width: full, height: tall, bottom: 0 };
		const height = tall - this.insets.bottom < MIN_FREE_SHARE * tall ? tall : tall - this.insets.bottom;
		return { left: this.insets.left, width: free, height, bottom: tall - height };

	}

	/** Container coordinates (CSS px) of a point projected by the camera (`ndc`: x, y in -1..1). */
	toContainer( ndc ) {

		const { left, width, height } = this.viewRect;
		return { x: left + ( ndc.x + 1 ) / 2 * width, y: ( 1 - ndc.y ) / 2 * height };

	}

	/** The rectangle `box` (world frame) covers on screen: { left, top, right, bottom } in container CSS px, or null if empty. */
	screenBox( box ) {

		if ( box.isEmpty() ) return null;
		const out = { left: Infinity, top: Infinity, right: - Infinity, bottom: - Infinity };
		for ( let corner = 0; corner < 8; corner ++ ) {

			_offset.set( corner & 1 ? box.max.x : box.min.x, corner & 2 ? box.max.y : box.min.y, corner & 4 ? box.max.z : box.min.z );
			const at = this.toContainer( _offset.project( this.camera ) );
			out.left = Math.min( out.left, at.x );
			out.right = Math.max( out.right, at.x );
			out.top = Math.min( out.top, at.y );
			out.bottom = Math.max( out.bottom, at.y );

		}
		return out;

	}

	/** The box of every visible robot (world frame); empty if none is shown. */
	worldBox( views, target = _box ) {

		target.makeEmpty();
		const one = new THREE.Box3();
		for ( const view of views ) target.union( view.worldBox( one ) );
		return target;

	}

	/** Point the camera at `box` from `direction` (unit vector, default: where it looks from now). */
	frameBox( box, direction = null ) {

		if ( box.isEmpty() ) return false;
		box.getSize( _size );
		box.getCenter( _centre );
		box.getBoundingSphere( _sphere );
		const radius = Math.max( _sphere.radius, 0.15 );
		const camera = this.camera;
		const halfV = THREE.MathUtils.degToRad( camera.fov ) / 2;
		const halfH = Math.atan( Math.tan( halfV ) * camera.aspect );
		const distance = radius / Math.sin( Math.min( halfV, halfH ) ) * 1.05;
		if ( direction === null ) direction = _offset.copy( camera.position ).sub( this.controls.target ).normalize();
		else direction = _offset.copy( direction );
		this.controls.target.copy( _centre );
		camera.position.copy( _centre ).addScaledVector( direction, distance );
		camera.near = distance / 100;
		camera.far = distance * 20;
		camera.updateProjectionMatrix();
		this.controls.update();
		return true;

	}

	/** Frame every visible robot from a preset direction (iso, top, front, side) or the current one. */
	frameAll( views, preset = null ) {

		const box = this.worldBox( views );
		const framed = this.frameBox( box, preset ? VIEWS[ preset ] : null );
		if ( framed ) this.fitShadow( box );
		return framed;

	}

	/** Fit the sun's shadow frustum around `box` (the robots). */
	fitShadow( box ) {

		if ( box.isEmpty() ) return;
		box.getCenter( _centre );
		box.getBoundingSphere( _sphere );
		const radius = Math.max( _sphere.radius, 0.3 );
		const shadow = this.sun.shadow.camera;
		const half = radius * 1.3;
		shadow.left = - half;
		shadow.right = half;
		shadow.top = half;
		shadow.bottom = - half;
		shadow.near = 0.1;
		shadow.far = 10 + radius * 4;
		this.sun.target.position.copy( _centre );
		this.sun.position.copy( _centre ).add( _offset.set( 2.5, - 1.5, 4.0 ) );
		shadow.updateProjectionMatrix();

	}

	resize() {

		this.viewRect = this._measureView();
		const { left, width, height } = this.viewRect;
		this.camera.aspect = width / height;
		this.camera.updateProjectionMatrix();
		this.renderer.setSize( width, height, false );
		this.gate.invalidate();
		const style = this.renderer.domElement.style;
		style.left = `${left}px`;
		style.width = `${width}px`;
		style.height = `${height}px`;
		for ( const gizmo of this._gizmos ) gizmo.viewport.set( left, this.viewRect.bottom, width, height );

	}

	/**
	 * A move/turn gizmo (three's TransformControls) in this view, its helper in the scene,
	 * hidden: while it is dragged the camera holds still, and `released` runs when it is
	 * let go. Its pointer is mapped to the canvas, not to the container the panels inset
	 * it in (the container's whole rectangle put the handles away from where they are drawn).
	 */
	gizmo( size, released ) {

		const controls = new TransformControls( this.camera, this.container );
		controls.setSize( size );
		controls.viewport = new THREE.Vector4();
		controls.addEventListener( 'dragging-changed', ( event ) => {

			this.controls.enabled = ! event.value;
			if ( ! event.value ) released();

		} );
		const helper = controls.getHelper();
		helper.visible = false;
		this.scene.add( helper );
		this._gizmos.push( controls );
		const { left, width, height, bottom } = this.viewRect;
		controls.viewport.set( left, bottom, width, height );
		return { controls, helper };

	}

	/**
	 * Draw a frame if it would show something new (frame_gate.js): a pose, the camera,
	 * anything shown or hidden, the size. Returns whether it drew.
	 */
	render() {

		this.controls.update();
		const changed = this.gate.changed( this.scene, this.camera );
		if ( ! changed && this.renderer.needsRedraw !== true ) return false;
		this.renderer.render( this.scene, this.camera );
		this.framesDrawn ++;
		return true;

	}

	dispose() {

		window.removeEventListener( 'resize', this._onResize );
		this._dark.removeEventListener( 'change', this._onTheme );
		this.renderer.setAnimationLoop( null );
		this.controls.dispose();
		this.floor.geometry.dispose();
		this.floor.material.dispose();
		this.grid.dispose();
		this.orientation.dispose();
		this._disposeEnvironment();
		this.renderer.dispose();
		this.renderer.domElement.remove();

	}

}

export { Stage, VIEWS };
