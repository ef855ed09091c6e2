export class View3D { constructor() { this.drawn = 0; } setCamera() {} sceneChanged() {} draw() {} }
